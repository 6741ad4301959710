/* The damped least-squares inverse by a one-sided Jacobi SVD (linalg.h). */
#include "linalg.h"

#include <float.h>
#include <math.h>

int ml_dls_scratch(int m, int n) {
  int k = m < n ? m : n, r = m < n ? n : m;
  return r * k + k * k + 3 * k;
}

void ml_dls_init(ml_dls* s, int m, int n, double* scratch) {
  s->m = m;
  s->n = n;
  s->k = m < n ? m : n;
  s->r = m < n ? n : m;
  s->transposed = m < n;
  s->weights = 0;
  s->cols = scratch;
  s->rot = s->cols + s->r * s->k;
  s->sigma = s->rot + s->k * s->k;
  s->gain = s->sigma + s->k;
  s->work = s->gain + s->k;
  s->lam2 = 0.0;
}

/* Rotate columns p and q of the (rows x ...) column-major `a` by (c, s). */
static void rotate(double* a, int rows, int p, int q, double c, double s) {
  double* ap = a + p * rows;
  double* aq = a + q * rows;
  for (int i = 0; i < rows; i++) {
    double x = ap[i], y = aq[i];
    ap[i] = c * x - s * y;
    aq[i] = s * x + c * y;
  }
}

/* Hestenes' one-sided Jacobi: rotate pairs of columns until every pair is orthogonal to
   round-off (|a_p . a_q| <= eps |a_p| |a_q|), accumulating the rotations in s->rot. A rank-deficient
   matrix ends with zero columns. The sweeps converge quadratically; 60 is far beyond need. */
static void jacobi(ml_dls* s) {
  int r = s->r, k = s->k;
  for (int sweep = 0; sweep < 60; sweep++) {
    int rotated = 0;
    for (int p = 0; p < k - 1; p++) {
      for (int q = p + 1; q < k; q++) {
        const double* ap = s->cols + p * r;
        const double* aq = s->cols + q * r;
        double alpha = 0.0, beta = 0.0, gamma = 0.0;
        for (int i = 0; i < r; i++) {
          alpha += ap[i] * ap[i];
          beta += aq[i] * aq[i];
          gamma += ap[i] * aq[i];
        }
        if (!(fabs(gamma) > DBL_EPSILON * sqrt(alpha) * sqrt(beta))) continue;
        /* the rotation that zeroes the pair's inner product, the smaller of the two angles */
        double zeta = (beta - alpha) / (2.0 * gamma);
        double t = copysign(1.0, zeta) / (fabs(zeta) + hypot(1.0, zeta));
        double c = 1.0 / sqrt(1.0 + t * t);
        rotate(s->cols, r, p, q, c, c * t);
        rotate(s->rot, k, p, q, c, c * t);
        rotated = 1;
      }
    }
    if (!rotated) break;
  }
}

void ml_dls_factor(ml_dls* s, const double* J, const double* weights, double damping,
                   double threshold) {
  int m = s->m, n = s->n, r = s->r, k = s->k;
  s->weights = weights;
  /* the columns of A = J diag(w) (m >= n), or of A^T, i.e. A's rows (m < n) */
  for (int i = 0; i < m; i++) {
    for (int j = 0; j < n; j++) {
      double a = weights ? J[i * n + j] * weights[j] : J[i * n + j];
      if (s->transposed) {
        s->cols[i * r + j] = a;
      } else {
        s->cols[j * r + i] = a;
      }
    }
  }
  for (int i = 0; i < k * k; i++) s->rot[i] = 0.0;
  for (int i = 0; i < k; i++) s->rot[i * k + i] = 1.0;
  jacobi(s);
  /* singular values are the columns' norms; the columns normalised are singular vectors (a zero
     column stays zero: its gain is 0 whatever it holds) */
  double smax = 0.0, smin = INFINITY;
  for (int j = 0; j < k; j++) {
    double* a = s->cols + j * r;
    double sum = 0.0;
    for (int i = 0; i < r; i++) sum += a[i] * a[i];
    double sigma = sqrt(sum);
    for (int i = 0; i < r; i++) a[i] = sigma > 0.0 ? a[i] / sigma : 0.0;
    s->sigma[j] = sigma;
    if (sigma > smax) smax = sigma;
    if (sigma < smin) smin = sigma;
  }
  if (k == 0) smin = 0.0;
  s->lam2 = threshold > 0.0 && smin < threshold
                ? damping * damping * (1.0 - (smin / threshold) * (smin / threshold))
                : 0.0;
  double tiny = 1e-12 * smax;
  for (int j = 0; j < k; j++) {
    double sigma = s->sigma[j];
    if (s->lam2 > 0.0) {
      s->gain[j] = sigma / (sigma * sigma + s->lam2);
    } else {
      s->gain[j] = sigma > tiny ? 1.0 / sigma : 0.0;
    }
  }
}

void ml_dls_solve(ml_dls* s, const double* rhs, int cols, double* x) {
  int m = s->m, n = s->n, r = s->r, k = s->k;
  /* A = U S V^T: U (m x k) and V (n x k) are the normalised columns and the rotations, which
     is which depending on whether the Jacobi ran on A or A^T */
  const double* U = s->transposed ? s->rot : s->cols;
  const double* V = s->transposed ? s->cols : s->rot;
  int ldu = s->transposed ? k : r, ldv = s->transposed ? r : k;
  for (int c = 0; c < cols; c++) {
    for (int j = 0; j < k; j++) { /* work = g (U^T b) */
      double sum = 0.0;
      for (int i = 0; i < m; i++) sum += U[j * ldu + i] * rhs[i * cols + c];
      s->work[j] = s->gain[j] * sum;
    }
    for (int i = 0; i < n; i++) { /* x = W V work */
      double sum = 0.0;
      for (int j = 0; j < k; j++) sum += V[j * ldv + i] * s->work[j];
      x[i * cols + c] = s->weights ? sum * s->weights[i] : sum;
    }
  }
}
