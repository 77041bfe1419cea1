"""Message types generated at import time from the .msg files.

toolpath_msgs comes from msg/msg/*.msg, the standard ROS 2 types the node
uses from crates/messages/src/defs/<pkg>/*.msg (the same texts the Rust crate embeds).
Each type becomes a Cyclone DDS IdlStruct named like rmw_cyclonedds names it
(``pkg::msg::dds_::Type_``), final extensibility, fields in .msg order, every
field defaulted (numbers 0, strings empty, sequences empty) as in rclpy.
Constants (``uint8 SUCCEEDED=2``) become class attributes.

``get("toolpath_msgs/Job")`` returns the class; the module also exposes every
type by its bare name (``msgs.Job``, ``msgs.PoseArray``...).
"""

import dataclasses
import os
import re

from cyclonedds.idl import IdlStruct
from cyclonedds.idl._main import IdlMeta
import cyclonedds.idl.annotations as _annotate
from cyclonedds.idl import types as _t

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))

_PRIMITIVES = {
    "bool": (bool, bool),
    "byte": (_t.uint8, int),
    "char": (_t.uint8, int),
    "float32": (_t.float32, float),
    "float64": (_t.float64, float),
    "int8": (_t.int8, int),
    "uint8": (_t.uint8, int),
    "int16": (_t.int16, int),
    "uint16": (_t.uint16, int),
    "int32": (_t.int32, int),
    "uint32": (_t.uint32, int),
    "int64": (_t.int64, int),
    "uint64": (_t.uint64, int),
    "string": (str, str),
    "wstring": (str, str),
}


def _sources():
    """Map 'pkg/Type' -> path of its .msg file."""
    out = {}
    own = os.path.join(ROOT, "msg", "msg")
    for f in sorted(os.listdir(own)):
        if f.endswith(".msg"):
            out["toolpath_msgs/" + f[:-4]] = os.path.join(own, f)
    defs = os.path.join(ROOT, "crates", "messages", "src", "defs")
    for pkg in sorted(os.listdir(defs)):
        for f in sorted(os.listdir(os.path.join(defs, pkg))):
            if f.endswith(".msg"):
                out[pkg + "/" + f[:-4]] = os.path.join(defs, pkg, f)
    return out


_SOURCES = _sources()
_CLASSES = {}


def _parse(full_name):
    """Fields [(name, type_token)] and constants {name: value} of a .msg file."""
    with open(_SOURCES[full_name]) as fh:
        return _parse_lines(fh)


def _parse_lines(lines):
    """Fields [(name, type_token)] and constants {name: value} of .msg text."""
    fields, constants = [], {}
    for raw in lines:
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        m = re.match(r"^(\S+)\s+([A-Za-z_][A-Za-z0-9_]*)\s*=\s*(.+)$", line)
        if m:
            ty, name, value = m.groups()
            base = _PRIMITIVES.get(ty)
            constants[name] = base[1](value) if base and base[1] is not str else value.strip("'\"")
            continue
        parts = line.split()
        fields.append((parts[1], parts[0]))
    return fields, constants


def _resolve(pkg, ty):
    if ty == "Header":
        return "std_msgs/Header"
    return ty if "/" in ty else pkg + "/" + ty


def _field_type(pkg, token):
    """(cyclonedds annotation, default factory) of a .msg type token."""
    m = re.match(r"^([^\[]+)(\[(<=)?(\d*)\])?$", token)
    base, arr, bounded, size = m.group(1), m.group(2), m.group(3), m.group(4)
    base = base.split("<=")[0]
    if base in _PRIMITIVES:
        elem, default = _PRIMITIVES[base]
    else:
        elem = get(_resolve(pkg, base))
        default = elem
    if arr is None:
        return elem, default
    if size and not bounded:
        n = int(size)
        return _t.array[elem, n], (lambda: [default() for _ in range(n)])
    if size:
        return _t.sequence[elem, int(size)], list
    return _t.sequence[elem], list


try:  # pragma: no cover - only with a ROS 2 installation
    import rclpy  # noqa: F401
    import toolpath_msgs.msg  # noqa: F401

    _USE_RCLPY = not os.environ.get("TOOLPATH_HARNESS_NO_RCLPY")
except ImportError:
    _USE_RCLPY = False


def get(full_name):
    """The class of 'pkg/Type': rclpy's when rclpy is importable, else generated."""
    if _USE_RCLPY:  # pragma: no cover
        import importlib

        pkg, name = full_name.split("/")
        cls = getattr(importlib.import_module(pkg + ".msg"), name)
        cls.ros_name = full_name
        return cls
    if full_name in _CLASSES:
        return _CLASSES[full_name]
    if full_name not in _SOURCES:
        raise KeyError("no .msg definition for %s" % full_name)
    pkg, name = full_name.split("/")
    fields, constants = _parse(full_name)
    typename = "%s::msg::dds_::%s_" % (pkg, name)
    cls = struct(name, typename, [(f,) + _field_type(pkg, token) for f, token in fields], constants)
    cls.ros_name = full_name
    _CLASSES[full_name] = cls
    return cls


def struct(name, typename, fields, constants=None):
    """A final IdlStruct named `typename` with fields [(name, annotation, default factory)]."""
    ns = IdlMeta.__prepare__(name, (IdlStruct,), typename=typename)
    for fname, ann, default in fields:
        ns["__annotations__"][fname] = ann
        ns[fname] = dataclasses.field(default_factory=default)
    cls = IdlMeta(name, (IdlStruct,), ns, typename=typename)
    cls = _annotate.final(cls)
    cls = dataclasses.dataclass(cls)
    for k, v in (constants or {}).items():
        setattr(cls, k, v)
    return cls


def sections(path, pkg, kind, name, parts):
    """The classes of the '---'-separated parts of a .srv or .action file, named
    as rmw_cyclonedds names them: ``pkg::<kind>::dds_::<name>_<part>_``."""
    with open(path) as fh:
        texts = re.split(r"^---\s*$", fh.read(), flags=re.M)
    assert len(texts) == len(parts), path
    out = []
    for part, text in zip(parts, texts):
        fields, constants = _parse_lines(text.splitlines())
        typename = "%s::%s::dds_::%s_%s_" % (pkg, kind, name, part)
        out.append(struct("%s_%s" % (name, part), typename,
                          [(f,) + _field_type(pkg, token) for f, token in fields], constants))
    return out


for _full in _SOURCES:
    globals()[_full.split("/")[1]] = get(_full)
