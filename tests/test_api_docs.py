"""Every public function and class documents its parameters (numpydoc), without running Sphinx.

"Public" is what a user reaches from ``import squealkit``: the names in the ``__all__`` of squealkit, of
each public subpackage and of each public top-level module (``squealkit.io``, ``squealkit.scale``,
``squealkit.uncertainty``), recursively through subpackages, and of the modules of ``squealkit.plotting``
(which has no package ``__all__``: its modules are what users import). A function or class that takes parameters
needs a Parameters section naming each of them (``*args``/``**kwargs`` may be left out); a function
needs a Returns (or Yields) section; a dataclass documents each public field, in its Parameters or
Attributes section. Pure introspection: well under a second.
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import pkgutil

import pytest

docscrape = pytest.importorskip("numpydoc.docscrape")

import squealkit  # noqa: E402


def _public_modules():
    """squealkit, its public subpackages (recursively) and its public top-level modules."""
    yield squealkit
    for info in pkgutil.walk_packages(squealkit.__path__, "squealkit."):
        parts = info.name.split(".")[1:]
        if any(p.startswith("_") for p in parts) or parts[0] == "cli":
            continue  # private; the CLI is documented from its commands (docs/cli.md)
        # a module inside a subpackage is public through its package's __all__; squealkit.plotting
        # has none: its modules are the public interface (``from squealkit.plotting.stability import ...``)
        if len(parts) == 1 or info.ispkg or parts[0] == "plotting":
            yield importlib.import_module(info.name)


def public_objects() -> dict[str, object]:
    """Qualified name -> object, for every callable named in a public ``__all__``."""
    out: dict[str, object] = {}
    for mod in _public_modules():
        for name in getattr(mod, "__all__", ()):
            obj = getattr(mod, name)
            if not callable(obj) or (inspect.isclass(obj) and issubclass(obj, BaseException)):
                continue  # constants; warnings and errors are documented by their one-line docstring
            key = f"{getattr(obj, '__module__', mod.__name__)}.{getattr(obj, '__qualname__', name)}"
            out.setdefault(key, obj)
    return out


def _names(section) -> set[str]:
    return {n.strip().lstrip("*") for p in section for n in p.name.split(",")}


def docstring_problems(obj) -> list[str]:
    """What the numpydoc docstring of ``obj`` lacks (empty when it is complete)."""
    try:
        doc = docscrape.NumpyDocString(inspect.getdoc(obj) or "")
    except Exception as e:  # numpydoc's own parse error: the section headings are malformed
        return [f"unparsable docstring ({e})"]
    documented = _names(doc["Parameters"]) | _names(doc["Other Parameters"])
    if dataclasses.is_dataclass(obj):
        fields = [f.name for f in dataclasses.fields(obj) if not f.name.startswith("_")]
        missing = [f for f in fields if f not in documented | _names(doc["Attributes"])]
        return [f"fields not in Parameters/Attributes: {', '.join(missing)}"] if missing else []
    try:
        sig = inspect.signature(obj)
    except (TypeError, ValueError):
        return []  # builtins and compiled objects without a signature
    params = [p.name for p in sig.parameters.values()
              if p.name not in ("self", "cls") and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)]
    problems = []
    missing = [p for p in params if p not in documented]
    if missing:
        problems.append(("no Parameters section" if not doc["Parameters"] else "Parameters section lacks")
                        + f": {', '.join(missing)}")
    if not inspect.isclass(obj) and not (doc["Returns"] or doc["Yields"]):
        problems.append("no Returns section")
    return problems


def test_walk_finds_the_public_api():
    objs = public_objects()
    # names the README and docs/api.md use, from several subpackages: the walk reaches them all
    for name in ("squealkit.stability.maps.stability_map",
                 "squealkit.measurement.analysis.recording.analyze_recording", "squealkit.transient.simulate.simulate",
                 "squealkit.models.rig.PinOnDiscRig",
                 "squealkit.uncertainty.squeal_propensity"):
        assert name in objs, name
    from squealkit.io import save_dataset

    assert any(obj is save_dataset for obj in objs.values())  # re-exported from a private module of squealkit.io
    assert len(objs) > 100


def test_every_public_callable_documents_its_parameters():
    problems = {name: p for name, obj in sorted(public_objects().items()) if (p := docstring_problems(obj))}
    assert not problems, "\n".join(f"{name}: {'; '.join(p)}" for name, p in problems.items())


def public_methods() -> dict[str, object]:
    """Qualified name -> function, for the public methods (and class/static methods) of public classes."""
    out: dict[str, object] = {}
    for name, cls in public_objects().items():
        if not inspect.isclass(cls):
            continue
        for mname, m in vars(cls).items():
            f = m.__func__ if isinstance(m, classmethod | staticmethod) else m
            if not mname.startswith("_") and inspect.isfunction(f):
                out[f"{name}.{mname}"] = getattr(cls, mname)  # bound for classmethods: no cls
    return out


def test_every_public_method_documents_its_parameters():
    """Methods need a Parameters section when they take parameters (a one-line summary saying what
    they return is enough for a Returns)."""
    problems = {name: [p for p in docstring_problems(m) if not p.startswith("no Returns")]
                for name, m in sorted(public_methods().items())}
    problems = {k: v for k, v in problems.items() if v}
    assert not problems, "\n".join(f"{name}: {'; '.join(p)}" for name, p in problems.items())


def test_the_checker_catches_a_missing_section():
    def undocumented(x, *, fs=1.0):
        """One line only."""
        return x

    def documented(x, *, fs=1.0):
        """Scale.

        Parameters
        ----------
        x : float
            A value [m].
        fs : float, default 1.0
            Sampling rate [Hz].

        Returns
        -------
        float
        """
        return x

    assert docstring_problems(undocumented) == ["no Parameters section: x, fs", "no Returns section"]
    assert docstring_problems(documented) == []
