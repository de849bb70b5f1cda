"""Writes the type stubs of the meshmark module (meshmark.pyi) from the signatures pybind11 puts
at the head of every docstring, so that the stubs cannot drift from the module.

Usage: python3 stubgen.py OUT.pyi   (with the built module importable: PYTHONPATH=build/python)
"""

import inspect
import re
import sys

import meshmark

HEADER = '''"""Type stubs of meshmark {version}, generated from the module by python/stubgen.py."""
# fmt: off
from typing import Any, Callable, Dict, Iterable, Iterator, List, Optional, Tuple, overload
import enum
import os
import numpy
'''


def elide_defaults(s):
    """Every default value of a signature replaced by ..., however nested its own brackets."""
    out, i, depth = [], 0, 0
    while i < len(s):
        c = s[i]
        if s.startswith("= ", i) and depth == 1:
            out.append("= ...")
            i += 2
            level = 0
            while i < len(s) and not (level == 0 and s[i] in ",)"):
                level += s[i] in "([{<"
                level -= s[i] in ")]}>"
                i += 1
            continue
        depth += c in "(["
        depth -= c in ")]"
        out.append(c)
        i += 1
    return "".join(out)


def clean(signature):
    """A pybind11 signature as valid Python: this module's names unqualified, numpy's shapes
    dropped, defaults elided, pybind11's handle and iterable types as object."""
    s = elide_defaults(signature.replace("meshmark.", ""))
    s = re.sub(r"numpy\.ndarray\[[^\]]*(\[[^\]]*\])?[^\]]*\]", "numpy.ndarray", s)
    s = re.sub(r"\bhandle\b", "object", s)
    s = re.sub(r"\bIterable\b(?!\[)", "Iterable[Any]", s)
    s = re.sub(r"\bIterator\b(?!\[)", "Iterator[Any]", s)
    s = re.sub(r"\bCallable\b(?!\[)", "Callable[..., Any]", s)
    return s


def signatures(name, doc):
    """The signatures a pybind11 docstring starts with (several for an overloaded function)."""
    if not doc:
        return [f"{name}(*args: Any, **kwargs: Any) -> Any"]
    lines = doc.splitlines()
    if len(lines) > 1 and lines[1].startswith("Overloaded function"):
        return [clean(m.group(1)) for m in re.finditer(rf"^\d+\. ({re.escape(name)}\(.*)$", doc, re.M)]
    if lines[0].startswith(name + "("):
        return [clean(lines[0])]
    return [f"{name}(*args: Any, **kwargs: Any) -> Any"]


def emit_function(out, name, obj, indent="", method=False):
    sigs = signatures(name, obj.__doc__)
    if method:  # a method without a signature in its docstring takes self and anything
        sigs = [f"{name}(self, *args: Any, **kwargs: Any) -> Any" if sig.startswith(f"{name}(*args")
                else sig for sig in sigs]
    for sig in sigs:
        if len(sigs) > 1:
            out.append(f"{indent}@overload")
        if method and "(self" not in sig:
            out.append(f"{indent}@staticmethod")
        out.append(f"{indent}def {sig}: ...")


def emit_class(out, name, cls):
    if isinstance(getattr(cls, "__members__", None), dict) and hasattr(cls, "value"):
        out.append(f"class {name}(enum.Enum):")
        for member in cls.__members__:
            out.append(f"    {member} = ...")
        out.append("")
        return
    base = "Exception" if issubclass(cls, BaseException) else "object"
    out.append(f"class {name}({base}):")
    body = []
    for attr, value in sorted(vars(cls).items()):
        if attr.startswith("__") and attr not in ("__init__", "__iter__", "__eq__", "__repr__"):
            continue
        if isinstance(value, property):
            doc = (value.fget.__doc__ or "") if value.fget else ""
            m = re.match(r"\(self: [^)]*\) -> (.*)", doc.splitlines()[0] if doc else "")
            kind = clean("x() -> " + m.group(1)).split("-> ", 1)[1] if m else "Any"
            body.append(f"    {attr}: {kind}")
        elif callable(value) or isinstance(value, staticmethod):
            target = value.__func__ if isinstance(value, staticmethod) else value
            emit_function(body, attr, target, "    ", method=True)
    out.extend(body or ["    ..."])
    out.append("")


def main():
    out = [HEADER.format(version=getattr(meshmark, "__version__", "?")).rstrip(), "", "__version__: str", ""]
    names = sorted(n for n in dir(meshmark) if not n.startswith("_"))
    for name in names:
        obj = getattr(meshmark, name)
        if inspect.isclass(obj):
            emit_class(out, name, obj)
    for name in names:
        obj = getattr(meshmark, name)
        if callable(obj) and not inspect.isclass(obj):
            emit_function(out, name, obj)
    text = "\n".join(out) + "\n"
    compile(text, sys.argv[1], "exec")  # the stubs must at least be valid Python
    with open(sys.argv[1], "w", encoding="utf-8") as f:
        f.write(text)
    print(f"stubgen: {sys.argv[1]}: {len(names)} names")


if __name__ == "__main__":
    main()
