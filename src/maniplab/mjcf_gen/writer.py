"""MJCF text of a spec at full float precision, written by walking the MjSpec that builds it.

``MjSpec.to_xml()`` prints every number with 6 significant digits and turns a full inertia into a
rounded principal frame (quat + diaginertia), which moves M(q) by ~1e-8 relative. This serialiser
writes every float as ``repr`` (shortest text that reads back to the same double) and the inertia
as ``fullinertia``, so ``mujoco.MjModel.from_xml_string(to_mjcf(spec))`` compiles to the same model
as :func:`~maniplab.mjcf_gen.builder.build_model`.

It is deliberately small: it covers the elements and attributes the builder uses (compiler, option,
visual, statistic, engine plugin instances, textures, materials, bodies with
inertial/joint/geom/site/camera/light, spatial tendons through sites, general and plugin actuators
on joints and tendons). An attribute is written only
when it differs from the value of a freshly created element of the same kind, which is also what
MuJoCo's XML parser assumes for an absent attribute.
"""

from __future__ import annotations

import dataclasses
import functools
import os
import re
import xml.etree.ElementTree as ET
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from maniplab.atomic import write_text
from maniplab.builtin import resolve_spec
from maniplab.mjcf_gen import builder

# (MjSpec attribute, XML attribute) per element kind, in the order they are written.
_Attrs = Sequence[tuple[str, str]]
_COMPILER: _Attrs = (
    ("inertiafromgeom", "inertiafromgeom"),
    ("boundmass", "boundmass"),
    ("boundinertia", "boundinertia"),
    ("balanceinertia", "balanceinertia"),
    ("settotalmass", "settotalmass"),
    ("autolimits", "autolimits"),
    ("fusestatic", "fusestatic"),
    ("alignfree", "alignfree"),
)
_OPTION: _Attrs = (
    ("timestep", "timestep"),
    ("integrator", "integrator"),
    ("gravity", "gravity"),
    ("wind", "wind"),
    ("magnetic", "magnetic"),
    ("density", "density"),
    ("viscosity", "viscosity"),
    ("impratio", "impratio"),
    ("tolerance", "tolerance"),
    ("iterations", "iterations"),
    ("ls_iterations", "ls_iterations"),
    ("cone", "cone"),
    ("jacobian", "jacobian"),
    ("solver", "solver"),
)
_VISUAL: dict[str, _Attrs] = {
    "global": (
        ("offwidth", "offwidth"),
        ("offheight", "offheight"),
        ("fovy", "fovy"),
        ("azimuth", "azimuth"),
        ("elevation", "elevation"),
    ),
    "headlight": (("ambient", "ambient"), ("diffuse", "diffuse"), ("specular", "specular")),
    "quality": (("shadowsize", "shadowsize"), ("offsamples", "offsamples")),
}
_STATISTIC: _Attrs = (("extent", "extent"), ("center", "center"))
_TEXTURE: _Attrs = (
    ("name", "name"),
    ("type", "type"),
    ("builtin", "builtin"),
    ("rgb1", "rgb1"),
    ("rgb2", "rgb2"),
    ("mark", "mark"),
    ("markrgb", "markrgb"),
    ("width", "width"),
    ("height", "height"),
)
_MATERIAL: _Attrs = (
    ("name", "name"),
    ("rgba", "rgba"),
    ("texrepeat", "texrepeat"),
    ("texuniform", "texuniform"),
    ("reflectance", "reflectance"),
    ("specular", "specular"),
    ("shininess", "shininess"),
    ("emission", "emission"),
)
_BODY: _Attrs = (("name", "name"), ("pos", "pos"), ("quat", "quat"), ("gravcomp", "gravcomp"))
_JOINT: _Attrs = (
    ("name", "name"),
    ("type", "type"),
    ("pos", "pos"),
    ("axis", "axis"),
    ("range", "range"),
    ("limited", "limited"),
    ("ref", "ref"),
    ("armature", "armature"),
    ("damping", "damping"),
    ("frictionloss", "frictionloss"),
    ("stiffness", "stiffness"),
    ("springref", "springref"),
)
_GEOM: _Attrs = (
    ("name", "name"),
    ("type", "type"),
    ("size", "size"),
    ("pos", "pos"),
    ("quat", "quat"),
    ("fromto", "fromto"),
    ("material", "material"),
    ("rgba", "rgba"),
    ("contype", "contype"),
    ("conaffinity", "conaffinity"),
    ("group", "group"),
)
_SITE: _Attrs = (
    ("name", "name"),
    ("type", "type"),
    ("size", "size"),
    ("pos", "pos"),
    ("quat", "quat"),
    ("material", "material"),
    ("rgba", "rgba"),
    ("group", "group"),
)
_CAMERA: _Attrs = (
    ("name", "name"),
    ("mode", "mode"),
    ("targetbody", "target"),
    ("pos", "pos"),
    ("quat", "quat"),
    ("fovy", "fovy"),
)
_LIGHT: _Attrs = (
    ("name", "name"),
    ("type", "type"),
    ("mode", "mode"),
    ("targetbody", "target"),
    ("pos", "pos"),
    ("dir", "dir"),
    ("cutoff", "cutoff"),
    ("exponent", "exponent"),
    ("castshadow", "castshadow"),
    ("ambient", "ambient"),
    ("diffuse", "diffuse"),
    ("specular", "specular"),
)
_TENDON: _Attrs = (
    ("name", "name"),
    ("group", "group"),
    ("limited", "limited"),
    ("actfrclimited", "actuatorfrclimited"),
    ("range", "range"),
    ("actfrcrange", "actuatorfrcrange"),
    ("solref_limit", "solreflimit"),
    ("solimp_limit", "solimplimit"),
    ("solref_friction", "solreffriction"),
    ("solimp_friction", "solimpfriction"),
    ("frictionloss", "frictionloss"),
    ("springyield", "springyield"),
    ("width", "width"),
    ("margin", "margin"),
    ("stiffness", "stiffness"),
    ("damping", "damping"),
    ("armature", "armature"),
    ("rgba", "rgba"),
    ("springlength", "springlength"),
    ("material", "material"),
)
_WRAPS = {  # the MJCF element of each kind of tendon wrap (a geom wrap is a sphere until compiled)
    mujoco.mjtWrap.mjWRAP_SITE: "site",
    mujoco.mjtWrap.mjWRAP_SPHERE: "geom",
    mujoco.mjtWrap.mjWRAP_CYLINDER: "geom",
    mujoco.mjtWrap.mjWRAP_PULLEY: "pulley",
    mujoco.mjtWrap.mjWRAP_JOINT: "joint",
}
_ACTUATOR: _Attrs = (
    ("name", "name"),
    ("gear", "gear"),
    ("ctrllimited", "ctrllimited"),
    ("ctrlrange", "ctrlrange"),
    ("forcelimited", "forcelimited"),
    ("forcerange", "forcerange"),
    ("actlimited", "actlimited"),
    ("actrange", "actrange"),
    ("actdim", "actdim"),
    ("dyntype", "dyntype"),
    ("gaintype", "gaintype"),
    ("biastype", "biastype"),
    ("dynprm", "dynprm"),
    ("gainprm", "gainprm"),
    ("biasprm", "biasprm"),
    ("actearly", "actearly"),
)
_PLUGIN_ACTUATOR = tuple(a for a in _ACTUATOR
                         if a[0] not in ("gaintype", "biastype", "gainprm", "biasprm"))
"""An engine plugin's actuator (``<plugin>``): the plugin computes the force, MJCF has no gain or
bias for it."""
_TRANSMISSION = {mujoco.mjtTrn.mjTRN_JOINT: "joint", mujoco.mjtTrn.mjTRN_TENDON: "tendon"}
_INT_ENUMS = {  # fields MjSpec stores as plain ints
    "integrator": mujoco.mjtIntegrator,
    "cone": mujoco.mjtCone,
    "jacobian": mujoco.mjtJacobian,
    "solver": mujoco.mjtSolver,
}
_SINGLE = {"reflectance", "specular", "shininess", "emission"}  # float32 scalars of a material
_KEYWORDS = {  # enum values whose MJCF keyword is not their lower-cased suffix
    mujoco.mjtIntegrator.mjINT_EULER: "Euler",
    mujoco.mjtIntegrator.mjINT_RK4: "RK4",
}


def to_mjcf(spec: builder.SpecLike) -> str:
    """MJCF text of ``spec`` at full float precision.

    The model is compiled and checked first (as :func:`build_model` does), so no file is produced
    for an arm that cannot be simulated.

    Args:
        spec: a spec, a spec file or a built-in spec name.

    Returns:
        The MJCF document; plain MuJoCo loads it into the same model as ``build_model(spec)``.

    Raises:
        SpecError: ``spec`` names no file or built-in, or the file is invalid.
        ModelError: the arm cannot be simulated (see :func:`build_model`).
    """
    spec = resolve_spec(spec)
    builder.build_model(spec)
    header = f" maniplab model of '{spec.name}'"
    if spec.source:
        header += f" from {Path(spec.source).name}"
    return serialize(builder.build_mjspec(spec), comment=header + "; generated by maniplab ")


def write_mjcf(spec: builder.SpecLike, path: str | os.PathLike[str]) -> Path:
    """Write ``to_mjcf(spec)`` to ``path`` atomically (temporary file, then rename).

    Args:
        spec: a spec, a spec file or a built-in spec name.
        path: the MJCF file to write; missing folders are created.

    Returns:
        The path written.
    """
    target = Path(path)
    write_text(target, to_mjcf(spec))
    return target


def serialize(s: mujoco.MjSpec, comment: str | None = None) -> str:
    """MJCF text of an MjSpec built by :func:`build_mjspec`, every float at full precision.

    Args:
        s: the MjSpec (not modified).
        comment: text of an XML comment at the top of the document, or None.

    Returns:
        The MJCF document.

    Raises:
        NotImplementedError: ``s`` holds elements this serialiser does not write (sensors,
            fixed tendons, geom wraps, site transmissions, ...), which would silently be lost.
    """
    _check_supported(s)
    root = ET.Element("mujoco", model=s.modelname)
    if comment:
        root.append(ET.Comment(comment_text(comment)))
    blank = _blank().spec
    angle = {"angle": "degree" if s.compiler.degree else "radian"}
    ET.SubElement(root, "compiler", angle | _attributes(s.compiler, _COMPILER, blank.compiler))
    _element(root, "option", s.option, _OPTION, blank.option)
    _write_visual(root, s)
    _element(root, "statistic", s.stat, _STATISTIC, blank.stat)
    _write_extension(root, s)
    _write_assets(root, s)
    _write_body(ET.SubElement(root, "worldbody"), s.worldbody, world=True)
    _write_tendons(root, s.tendons)
    _write_actuators(root, s.actuators)
    _write_keys(root, s)
    ET.indent(root, space="  ")
    return ET.tostring(root, encoding="unicode") + "\n"


def comment_text(text: str) -> str:
    """``text`` made safe inside an XML comment (``<!--text-->``), which cannot hold ``--`` nor
    end in ``-``: control and other unprintable characters are dropped, and every ``-`` that is
    followed by another gets a space after it (ElementTree writes a comment's text as it is)."""
    printable = "".join(c for c in text if c.isprintable() or c == " ")
    spaced = re.sub(r"-(?=-)", "- ", printable)
    return spaced + " " if spaced.endswith("-") else spaced


def _check_supported(s: mujoco.MjSpec) -> None:
    kinds = ("sensors", "equalities", "meshes", "hfields", "flexes", "pairs", "excludes",
             "skins", "numerics", "texts", "tuples", "frames")
    present = [kind for kind in kinds if len(getattr(s, kind))]
    for tendon in s.tendons:
        wraps = sorted({_WRAPS[wrap.type] for wrap in tendon.path} - {"site"})
        present += [f"{kind} wraps of tendon {tendon.name!r}" for kind in wraps]
    present += [f"{_format(act.trntype)} transmission of actuator {act.name!r}"
                for act in s.actuators if act.trntype not in _TRANSMISSION]
    if present:
        raise NotImplementedError(f"the MJCF writer cannot write {', '.join(present)} yet")


def _write_visual(root: ET.Element, s: mujoco.MjSpec) -> None:
    visual = ET.SubElement(root, "visual")
    blank = _blank().spec.visual
    for tag, attr in (("global", "global_"), ("headlight", "headlight"), ("quality", "quality")):
        values = _attributes(getattr(s.visual, attr), _VISUAL[tag], getattr(blank, attr))
        if values:
            ET.SubElement(visual, tag, values)


def _write_assets(root: ET.Element, s: mujoco.MjSpec) -> None:
    asset = ET.SubElement(root, "asset")
    blank = _blank()
    for texture in s.textures:
        _element(asset, "texture", texture, _TEXTURE, blank.texture)
    for material in s.materials:
        element = _element(asset, "material", material, _MATERIAL, blank.material)
        rgb = material.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB]
        if rgb:
            element.set("texture", rgb)


def _write_body(element: ET.Element, body: mujoco.MjsBody, world: bool = False) -> None:
    """Children of ``body`` into ``element`` (the body's own attributes are already written)."""
    blank = _blank()
    if not world:
        _write_inertial(element, body)
    for joint in body.joints:
        _element(element, "joint", joint, _JOINT, blank.joint)
    for geom in body.geoms:
        _element(element, "geom", geom, _GEOM, blank.geom)
    for site in body.sites:
        _element(element, "site", site, _SITE, blank.site)
    for camera in body.cameras:
        _element(element, "camera", camera, _CAMERA, blank.camera)
    for light in body.lights:
        _element(element, "light", light, _LIGHT, blank.light)
    for child in body.bodies:
        _write_body(_element(element, "body", child, _BODY, blank.body), child)


def _write_inertial(element: ET.Element, body: mujoco.MjsBody) -> None:
    full = np.asarray(body.fullinertia)
    attrs = {"pos": _format(body.ipos), "mass": _format(body.mass)}
    if np.isnan(full[0]):
        attrs.update(quat=_format(body.iquat), diaginertia=_format(body.inertia))
    else:
        attrs["fullinertia"] = _format(full)
    ET.SubElement(element, "inertial", attrs)


def _write_extension(root: ET.Element, s: mujoco.MjSpec) -> None:
    """The engine plugins and their instances, each parameter as the text the spec holds.

    The instances keep the spec's order (a ``<plugin>`` element per run of instances of one
    plugin): MuJoCo numbers plugin instances in the order the file lists them, and the compiled
    file must number them as the spec does (``actuator_plugin``, the plugins' state addresses).
    Grouping every instance of a plugin under one element reordered them on an arm whose plugins
    alternate (a lumped, a pinned, a lumped cylinder).
    """
    runs: list[tuple[str, list[mujoco.MjsPlugin]]] = []
    for instance in s.plugins:
        if not runs or runs[-1][0] != instance.plugin_name:
            runs.append((instance.plugin_name, []))
        runs[-1][1].append(instance)
    if not runs:
        return
    section = ET.SubElement(root, "extension")
    for plugin, members in runs:
        element = ET.SubElement(section, "plugin", plugin=plugin)
        for instance in members:
            item = ET.SubElement(element, "instance", name=instance.name)
            for key, value in instance.config.items():
                ET.SubElement(item, "config", key=key, value=value)


def _write_tendons(root: ET.Element, tendons: Sequence[mujoco.MjsTendon]) -> None:
    """The spatial tendons, each a path through sites (the only wraps ``_check_supported`` lets
    through)."""
    if not tendons:
        return
    section = ET.SubElement(root, "tendon")
    for tendon in tendons:
        element = _element(section, "spatial", tendon, _TENDON, _blank().tendon)
        for wrap in tendon.path:
            ET.SubElement(element, "site", site=wrap.target.name)


def _write_actuators(root: ET.Element, actuators: Iterable[mujoco.MjsActuator]) -> None:
    section = ET.SubElement(root, "actuator")
    for act in actuators:
        plugin = act.plugin.active
        attrs = _attributes(act, _PLUGIN_ACTUATOR if plugin else _ACTUATOR, _blank().actuator)
        head = {"name": attrs.pop("name")} if "name" in attrs else {}
        target = {_TRANSMISSION[act.trntype]: act.target}
        if plugin:
            target["instance"] = act.plugin.name
        ET.SubElement(section, "plugin" if plugin else "general", head | target | attrs)


def _write_keys(root: ET.Element, s: mujoco.MjSpec) -> None:
    """The keyframes: their name and activations (the only parts the builder sets; the rest of a
    key is the model's default: qpos0, zero velocities and controls)."""
    if not len(s.keys):
        return
    section = ET.SubElement(root, "keyframe")
    for key in s.keys:
        _check_key(key)
        attrs = {"name": key.name} if key.name else {}
        if len(key.act):
            attrs["act"] = _format(key.act)
        ET.SubElement(section, "key", attrs)


def _check_key(key: mujoco.MjsKey) -> None:
    rest = [field for field in ("qpos", "qvel", "ctrl", "mpos", "mquat") if len(getattr(key, field))]
    if rest or key.time:
        raise NotImplementedError(f"the MJCF writer cannot write a keyframe's "
                                  f"{', '.join(rest) or 'time'} yet")


def _element(parent: ET.Element, tag: str, obj: Any, attrs: _Attrs, default: Any) -> ET.Element:
    """Sub-element ``tag`` of ``parent`` with the attributes of ``obj`` that differ from ``default``."""
    return ET.SubElement(parent, tag, _attributes(obj, attrs, default))


def _attributes(obj: Any, attrs: _Attrs, default: Any) -> dict[str, str]:
    return {
        xml: _format(_typed(name, value))
        for name, xml in attrs
        if _differs(value := getattr(obj, name), getattr(default, name))
    }


def _typed(name: str, value: Any) -> Any:
    """Restore the type MjSpec loses for some fields: enums stored as ints, float32 scalars."""
    if name in _INT_ENUMS:
        return _INT_ENUMS[name](value)
    if name in _SINGLE and isinstance(value, float):
        return np.float32(value)
    return value


def _differs(value: Any, default: Any) -> bool:
    if isinstance(value, (str, bool)) or _is_enum(value):
        return bool(value != default)
    return not np.array_equal(np.asarray(value), np.asarray(default), equal_nan=True)


def _format(value: Any) -> str:
    """MJCF text of a value: round-trip exact numbers, keywords for enums, true/false."""
    if isinstance(value, str):
        return value
    if isinstance(value, (bool, np.bool_)):
        return "true" if value else "false"
    if _is_enum(value):
        return _KEYWORDS.get(value) or value.name.split("_", 1)[1].lower()
    array = np.asarray(value)
    if array.dtype == np.float32:  # colours and the like: the shortest text of the float32
        return " ".join(_number(float(v), str(v)) for v in array.reshape(-1))
    if array.ndim:
        return " ".join(_format(v) for v in array.tolist())
    if np.issubdtype(array.dtype, np.integer):
        return str(int(value))
    return _number(float(value), repr(float(value)))


def _number(value: float, text: str) -> str:
    """``text`` for ``value``, but integral values as integers and -0.0 as 0 (same double)."""
    if value.is_integer() and abs(value) < 2**53:
        return str(int(value))
    return text


def _is_enum(value: Any) -> bool:
    return type(value).__name__.startswith("mjt")


@dataclasses.dataclass(frozen=True)
class _Blank:
    """One element of each kind, as MuJoCo creates it: the values an absent MJCF attribute means."""

    spec: mujoco.MjSpec  # keeps the elements below alive
    body: mujoco.MjsBody
    joint: mujoco.MjsJoint
    geom: mujoco.MjsGeom
    site: mujoco.MjsSite
    camera: mujoco.MjsCamera
    light: mujoco.MjsLight
    tendon: mujoco.MjsTendon
    actuator: mujoco.MjsActuator
    texture: mujoco.MjsTexture
    material: mujoco.MjsMaterial


@functools.cache
def _blank() -> _Blank:
    s = mujoco.MjSpec()
    body = s.worldbody.add_body()
    return _Blank(
        s,
        body,
        body.add_joint(),
        body.add_geom(),
        body.add_site(),
        body.add_camera(),
        body.add_light(),
        s.add_tendon(),
        s.add_actuator(),
        s.add_texture(),
        s.add_material(),
    )
