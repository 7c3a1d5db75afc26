"""Effects, predictors and dialects written outside the package: finding, loading, recording.

A plugin is a Python file (or a folder of them) or an installed package. It is found
three ways, all loaded by ``load_plugins``:

- a path given by ``--plugins PATH`` (repeatable; a ``.py`` file or a folder of them);
- the environment variable ``POSTPROC_PLUGINS`` (paths separated by ``os.pathsep``);
- the entry-point groups ``postproc.model.effects``, ``postproc.predictors`` and
  ``postproc.programs.dialects`` of installed distributions (the entry point names a module, or
  the class / dialect object itself).

In a loaded module, every ``Effect`` subclass with a ``name`` defined there becomes an
effect, every ``PluginPredictor`` subclass a predictor, every ``Dialect`` instance a
dialect. Each gets a ``PluginRecord`` (its module, file and the sha256 of that file);
the model file keeps the records of the plugins it uses and refuses a model whose plugin
is not loaded or has changed (``plugin_records``, which model files import: it knows no
language).
"""

from __future__ import annotations

import hashlib
import importlib.metadata
import importlib.util
import inspect
import os
import shlex
import sys
from pathlib import Path
from types import ModuleType
from typing import Iterable

from postproc.model import effects as effect_registry
from postproc.model import predictor_plugins as predictor_registry
from postproc.model.effects.base import Effect
from postproc.model.plugin_records import ENV, HOW_TO_LOAD, RECORD_ATTR, PluginRecord, check_model_plugins, plugin_document, plugin_record  # noqa: F401  (callers take them from here too)
from postproc.model.predictor_plugins import PluginPredictor
from postproc.programs import dialects as dialect_registry
from postproc.programs.dialects.base import Dialect

from .errors import InputError

GROUPS = {"effect": "postproc.effects", "predictor": "postproc.predictors", "dialect": "postproc.dialects"}


class PluginError(InputError):
    """A plugin that cannot be loaded: missing path, a Python error in it, a name clash."""


# ----------------------------------------------------------------- loading


def plugin_paths(paths: Iterable[str | Path] = (), environ=None) -> list[tuple[Path, str]]:
    """(path, origin) of every plugin path given on the command line, then in POSTPROC_PLUGINS."""
    environ = os.environ if environ is None else environ
    given = [(Path(p), "--plugins") for p in paths]
    env = [(Path(p), ENV) for p in environ.get(ENV, "").split(os.pathsep) if p.strip()]
    return given + env


def load_plugins(paths: Iterable[str | Path] = (), *, environ=None, entry_points: bool = True) -> list[PluginRecord]:
    """Load the plugins at ``paths``, in ``POSTPROC_PLUGINS`` and (``entry_points``) of installed
    packages, registering what they define; returns the records. Loading the same file
    again is a no-op; a changed file is loaded anew and replaces its own definitions."""
    records: list[PluginRecord] = []
    for path, origin in plugin_paths(paths, environ):
        for file in _python_files(path, origin):
            records += _register_module(_load_file(file, origin), origin, file)
    if entry_points:
        records += _load_entry_points()
    return records


def _python_files(path: Path, origin: str) -> list[Path]:
    if path.is_dir():
        files = sorted(p for p in path.glob("*.py") if not p.name.startswith("_"))
        if not files:
            raise PluginError(f"{origin} {path}: a folder with no .py file")
        return files
    if path.is_file():
        if path.suffix != ".py":
            raise PluginError(f"{origin} {path}: not a .py file")
        return [path]
    raise PluginError(f"{origin} {path}: no such file or folder")


def module_name_for(file: Path) -> str:
    """The module name a plugin file is loaded under: stable for one location (so a forked
    or spawned worker resolves a pickled plugin class to the same module), distinct for two
    files of the same name in different folders."""
    where = hashlib.sha256(str(file.resolve()).encode()).hexdigest()[:10]
    stem = "".join(c if c.isalnum() else "_" for c in file.stem)
    return f"postproc_plugin_{stem}_{where}"


def file_sha256(file: Path) -> str:
    return hashlib.sha256(file.read_bytes()).hexdigest()


def _load_file(file: Path, origin: str) -> ModuleType:
    name = module_name_for(file)
    try:
        digest = file_sha256(file)
    except OSError as exc:
        raise PluginError(f"{origin} {file}: cannot read ({exc.strerror})") from None
    loaded = sys.modules.get(name)
    if loaded is not None and getattr(loaded, "__postproc_sha256__", None) == digest:
        return loaded
    spec = importlib.util.spec_from_file_location(name, file)
    module = importlib.util.module_from_spec(spec)
    module.__postproc_sha256__ = digest
    sys.modules[name] = module  # before exec: dataclasses and pickle look the module up by name
    try:
        spec.loader.exec_module(module)
    except Exception as exc:  # noqa: BLE001 - any error in the user's file is reported as bad input
        del sys.modules[name]
        line = _error_line(exc, file)
        raise PluginError(f"{file}{line}: the plugin cannot be loaded ({type(exc).__name__}: {exc})") from None
    return module


def _error_line(exc: Exception, file: Path) -> str:
    if isinstance(exc, SyntaxError) and exc.lineno:
        return f", line {exc.lineno}, column {exc.offset or 1}"
    frames = [f for f in inspect.getinnerframes(exc.__traceback__) if Path(f.filename) == file] if exc.__traceback__ else []
    return f", line {frames[-1].lineno}" if frames else ""


def _register_module(module: ModuleType, origin: str, file: Path | None) -> list[PluginRecord]:
    """Register what ``module`` defines; an empty plugin is an error (a wrong file)."""
    found = [obj for _, obj in inspect.getmembers(module) if _defines(module, obj)]
    if not found:
        raise PluginError(f"{file or module.__name__}: defines no Effect subclass with a name, PluginPredictor subclass or Dialect object")
    return [_register(obj, module, origin, file) for obj in found]


def _defines(module: ModuleType, obj) -> bool:
    if isinstance(obj, type):
        own = obj.__module__ == module.__name__
        return own and bool(getattr(obj, "name", "")) and (issubclass(obj, Effect) or issubclass(obj, PluginPredictor))
    return isinstance(obj, Dialect) and type(obj).__module__ == module.__name__ and bool(obj.name)


def _register(obj, module: ModuleType, origin: str, file: Path | None) -> PluginRecord:
    where = str(file or module.__name__)
    source = file if file is not None else _source_file(module)
    digest = getattr(module, "__postproc_sha256__", None) or (file_sha256(source) if source is not None else None)
    if isinstance(obj, Dialect):
        kind, register = "dialect", dialect_registry.register
    elif issubclass(obj, Effect):
        kind, register = "effect", effect_registry.register
    else:
        kind, register = "predictor", predictor_registry.register
    record = PluginRecord(kind, obj.name, module.__name__, None if source is None else str(source.resolve()), digest, origin)
    try:
        register(obj, where)
    except InputError as exc:  # a name clash or a bad declaration: one error type for every plugin problem
        raise PluginError(str(exc)) from None
    object.__setattr__(obj, RECORD_ATTR, record) if isinstance(obj, Dialect) else setattr(obj, RECORD_ATTR, record)
    if file is not None and isinstance(obj, type):
        obj.__reduce__ = _reduce_plugin_object  # pickled by file: a spawned process loads the file first
    return record


def _reduce_plugin_object(self):
    """Pickle an instance of a plugin class loaded from a file as (file, class, state), so
    that a process that never loaded the file (a spawned worker) loads it on unpickling."""
    record = plugin_record(type(self))
    return _rebuild_plugin_object, (record.file, type(self).__qualname__, self.__dict__)


def _rebuild_plugin_object(file: str, qualname: str, state: dict):
    module = _load_file(Path(file), "a pickled plugin object's")
    _register_module(module, "--plugins", Path(file))
    obj = object.__new__(getattr(module, qualname))
    obj.__dict__.update(state)
    return obj


def _source_file(module: ModuleType) -> Path | None:
    file = getattr(module, "__file__", None)
    return Path(file) if file else None


def _load_entry_points() -> list[PluginRecord]:
    records = []
    for kind, group in GROUPS.items():
        for ep in importlib.metadata.entry_points(group=group):
            origin = f"entry point {ep.name} ({group})"
            try:
                target = ep.load()
            except Exception as exc:  # noqa: BLE001 - a broken installed plugin is reported, naming it
                raise PluginError(f"{origin} = {ep.value}: cannot be loaded ({type(exc).__name__}: {exc})") from None
            module = target if isinstance(target, ModuleType) else sys.modules[target.__module__ if isinstance(target, type) else type(target).__module__]
            if isinstance(target, ModuleType):
                records += _register_module(module, origin, None)
            elif _defines(module, target):
                records.append(_register(target, module, origin, None))
            else:
                raise PluginError(f"{origin} = {ep.value}: not a module, an Effect or PluginPredictor subclass, or a Dialect object")
    return records


def loaded_plugin_files() -> list[str]:
    """The files of every plugin loaded from a path (for workers, which load them again)."""
    records = [plugin_record(obj) for obj in _registered()]
    return sorted({r.file for r in records if r is not None and r.file and not r.origin.startswith("entry point")})


def plugin_arguments() -> str:
    """' --plugins F' for each loaded plugin file (shell-quoted; '' when none): appended to the
    commands postproc suggests, so that they load what this command loaded."""
    return "".join(f" --plugins {shlex.quote(file)}" for file in loaded_plugin_files())


def _registered() -> list:
    return [*effect_registry.CATALOG.values(), *predictor_registry.PREDICTORS.values(), *dialect_registry.REGISTRY.values()]
