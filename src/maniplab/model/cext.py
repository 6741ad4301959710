"""The C translation unit of a compiled model: kernels plus a minimal CPython extension around them.

The extension is what makes a call cheap from Python (about a microsecond all in): METH_FASTCALL
functions, no per-argument conversion layer (ctypes spends more than the arithmetic), numpy arrays
checked in place, the output allocated once, and a batch of states ``(N, n)`` looped in C. The
kernels keep plain C linkage, so the same shared library also serves ctypes when Python's headers
are missing.

Python-visible functions, one per kernel: ``<name>(p, q[, qd[, qdd]]) -> ndarray`` where every
state argument is shape (n,) or (N, n) (float64, anything numpy can convert) and the result is
the kernel's shape, or (N, *shape) for a batch.
"""

from __future__ import annotations

import math

from maniplab.model.tape import TapeKernel

_WRAPPER = r"""
#ifdef ML_PYTHON
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#define NPY_NO_DEPRECATED_API NPY_1_7_API_VERSION
#include <numpy/arrayobject.h>
#include <string.h>

typedef void (*ml_kernel)(const double *, const double *, const double *, const double *, double *);
/* a kernel: its inputs, and one output (ndim2 = 0) or two written one after the other */
typedef struct {
    const char *name; ml_kernel fn; int nin;
    int ndim; npy_intp shape[2]; int ndim2; npy_intp shape2[2];
} ml_entry;

static npy_intp ml_size(int ndim, const npy_intp *shape)
{
    npy_intp size = 1;
    int i;
    for (i = 0; i < ndim; i++) size *= shape[i];
    return size;
}

static PyObject *ml_new(npy_intp batch, int ndim, const npy_intp *shape)
{
    npy_intp dims[3];
    int i, nd = 0;
    if (batch >= 0) dims[nd++] = batch;
    for (i = 0; i < ndim; i++) dims[nd++] = shape[i];
    return PyArray_SimpleNew(nd, dims, NPY_DOUBLE);
}

static PyArrayObject *ml_array(PyObject *obj)
{
    if (PyArray_CheckExact(obj)) {
        PyArrayObject *a = (PyArrayObject *)obj;
        if (PyArray_TYPE(a) == NPY_DOUBLE && PyArray_IS_C_CONTIGUOUS(a) && PyArray_ISALIGNED(a)) {
            Py_INCREF(obj);
            return a;
        }
    }
    return (PyArrayObject *)PyArray_FROMANY(obj, NPY_DOUBLE, 0, 0, NPY_ARRAY_IN_ARRAY);
}

/* Evaluate a kernel for one state or a batch; returns an array, or a pair for two outputs. */
static PyObject *ml_call(const ml_entry *e, PyObject *const *args, Py_ssize_t nargs)
{
    PyArrayObject *a[4] = {NULL, NULL, NULL, NULL};
    const double *ptr[4] = {NULL, NULL, NULL, NULL};
    PyObject *result = NULL, *second = NULL;
    npy_intp batch = -1;
    int i;
    if (nargs != 1 + e->nin) {
        PyErr_Format(PyExc_TypeError, "%s() takes %d arguments (%zd given)", e->name, 1 + e->nin,
                     nargs);
        return NULL;
    }
    for (i = 0; i < nargs; i++) {
        if (!(a[i] = ml_array(args[i]))) goto done;
        ptr[i] = (const double *)PyArray_DATA(a[i]);
    }
    if (PyArray_NDIM(a[0]) != 1 || PyArray_DIM(a[0], 0) != ML_NP) {
        PyErr_Format(PyExc_ValueError, "%s(): p must have shape (%d,)", e->name, ML_NP);
        goto done;
    }
    if (PyArray_NDIM(a[1]) == 2 && PyArray_DIM(a[1], 1) == ML_N) {
        batch = PyArray_DIM(a[1], 0);
    } else if (!(PyArray_NDIM(a[1]) == 1 && PyArray_DIM(a[1], 0) == ML_N)) {
        PyErr_Format(PyExc_ValueError, "%s(): q must have shape (%d,) or (N, %d)", e->name, ML_N, ML_N);
        goto done;
    }
    for (i = 2; i < nargs; i++) {
        if (PyArray_NDIM(a[i]) != PyArray_NDIM(a[1]) ||
            !PyArray_CompareLists(PyArray_DIMS(a[i]), PyArray_DIMS(a[1]), PyArray_NDIM(a[1]))) {
            PyErr_Format(PyExc_ValueError, "%s(): %s must have the shape of q", e->name,
                         i == 2 ? "qd" : "qdd");
            goto done;
        }
    }
    if (!(result = ml_new(batch, e->ndim, e->shape))) goto done;
    if (e->ndim2 && !(second = ml_new(batch, e->ndim2, e->shape2))) {
        Py_CLEAR(result);
        goto done;
    }
    {
        npy_intp k, count = batch < 0 ? 1 : batch;
        npy_intp size = ml_size(e->ndim, e->shape), size2 = ml_size(e->ndim2, e->shape2);
        double *out = (double *)PyArray_DATA((PyArrayObject *)result);
        double *out2 = second ? (double *)PyArray_DATA((PyArrayObject *)second) : NULL;
        double buffer[ML_N * ML_N + ML_N];
        PyThreadState *released = count > 256 ? PyEval_SaveThread() : NULL;  /* a long batch */
        for (k = 0; k < count; k++) {
            const double *qd = ptr[2] ? ptr[2] + k * ML_N : NULL;
            const double *qdd = ptr[3] ? ptr[3] + k * ML_N : NULL;
            if (!second) {
                e->fn(ptr[0], ptr[1] + k * ML_N, qd, qdd, out + k * size);
            } else {  /* two outputs: the kernel writes both into one buffer */
                e->fn(ptr[0], ptr[1] + k * ML_N, qd, qdd, buffer);
                memcpy(out + k * size, buffer, size * sizeof(double));
                memcpy(out2 + k * size2, buffer + size, size2 * sizeof(double));
            }
        }
        if (released) PyEval_RestoreThread(released);
    }
    if (second) {
        PyObject *pair = PyTuple_Pack(2, result, second);
        Py_DECREF(result);
        Py_DECREF(second);
        result = pair;
    }
done:
    for (i = 0; i < 4; i++) Py_XDECREF(a[i]);
    return result;
}
"""


def extension_source(kernels: list[TapeKernel], module_name: str, n: int, nparams: int) -> str:
    """The Python wrapper's translation unit (compiled with -DML_PYTHON) for ``kernels``, which
    are compiled separately (their ``ml_<name>`` symbols are declared here)."""
    for k in kernels:  # a split kernel's outputs must fit ml_call's stack buffer
        assert not k.second or sum(math.prod(s) for s in k.output_shapes) <= n * n + n

    def dims(shape: tuple[int, ...]) -> str:
        return f"{len(shape)}, {{{', '.join(str(s) for s in shape) or '0'}}}"

    declarations = "\n".join(
        f"void ml_{k.name}(const double *p, const double *q, const double *qd, "
        "const double *qdd, double *out);" for k in kernels)
    table = ",\n    ".join(
        f'{{"{k.name}", ml_{k.name}, {k.nin}, {dims(k.shape)}, {dims(k.second)}}}'
        for k in kernels)
    wrappers = "\n".join(
        f"static PyObject *py_{k.name}(PyObject *self, PyObject *const *args, "
        f"Py_ssize_t nargs)\n{{ (void)self; return ml_call(&ML_TABLE[{i}], args, nargs); }}"
        for i, k in enumerate(kernels))
    methods = ",\n    ".join(
        f'{{"{k.name}", (PyCFunction)(void (*)(void))py_{k.name}, METH_FASTCALL, "{k.doc}"}}'
        for k in kernels)
    header = f"#define ML_N {n}\n#define ML_NP {max(nparams, 1)}\n{declarations}\n"
    return header + f"""{_WRAPPER}
static const ml_entry ML_TABLE[] = {{
    {table}
}};

{wrappers}

static PyMethodDef ML_METHODS[] = {{
    {methods},
    {{NULL, NULL, 0, NULL}}
}};

static struct PyModuleDef ML_MODULE = {{
    PyModuleDef_HEAD_INIT, "{module_name}", "maniplab generated model", -1, ML_METHODS,
    NULL, NULL, NULL, NULL
}};

PyMODINIT_FUNC PyInit_{module_name}(void)
{{
    import_array();
    return PyModule_Create(&ML_MODULE);
}}
#endif /* ML_PYTHON */
"""
