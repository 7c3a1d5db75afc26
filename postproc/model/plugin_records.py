"""Where a plugin came from (``PluginRecord``), and what a model file says of the plugin
effects and predictor it uses: ``plugin_document`` writes it, ``check_model_plugins``
refuses a model whose plugin is not loaded or has changed. Model files (``model_io``)
import this, not ``plugins`` (which loads dialects too): no language below the programs.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

from postproc.errors import ModelFileError

from . import effects as effect_registry
from . import predictor_plugins as predictor_registry

ENV = "POSTPROC_PLUGINS"
RECORD_ATTR = "__postproc_plugin__"
HOW_TO_LOAD = f"--plugins PATH (a .py file or a folder of them), the environment variable {ENV}, or an installed package's 'postproc.effects' entry point"


@dataclass(frozen=True)
class PluginRecord:
    """Where a plugin effect, predictor or dialect came from."""

    kind: str  # effect, predictor or dialect
    name: str
    module: str
    file: str | None
    sha256: str | None  # of the file's bytes
    origin: str  # --plugins, POSTPROC_PLUGINS, or entry point DIST

    def as_dict(self) -> dict:
        return asdict(self)


def plugin_record(obj) -> PluginRecord | None:
    """The record of a plugin class or dialect object; None for a built-in."""
    return getattr(obj, RECORD_ATTR, None) if isinstance(getattr(obj, RECORD_ATTR, None), PluginRecord) else None


# ------------------------------------------------------------ model files


def plugin_document(model) -> dict:
    """``{"plugins": [records]}`` for the plugin effects and predictor a model uses; {} when none."""
    objs = [type(effect) for effect in model.effects]
    if model.residual is not None:
        objs.append(predictor_registry.PREDICTORS.get(model.residual.kind))
    records = [plugin_record(obj) for obj in objs if obj is not None]
    return {"plugins": [r.as_dict() for r in records if r is not None]} if any(records) else {}


def check_model_plugins(doc: dict, source: str) -> None:
    """Refuse a model whose plugin effects or predictor are not loaded, or not the source it was fitted with."""
    recorded = doc.get("plugins", [])
    if not isinstance(recorded, list) or not all(isinstance(r, dict) and {"kind", "name", "sha256"} <= set(r) for r in recorded):
        raise ModelFileError(f"{source}: key 'plugins': must be a list of {{kind, name, module, file, sha256}}")
    tables = {"effect": effect_registry.CATALOG, "predictor": predictor_registry.PREDICTORS}
    for entry in recorded:
        what = f"{entry['kind']} '{entry['name']}' (from {entry.get('file') or entry.get('module')})"
        loaded = tables.get(entry["kind"], {}).get(entry["name"])
        if loaded is None:
            hint = f"--plugins {entry['file']} (or POSTPROC_PLUGINS)" if entry.get("file") else HOW_TO_LOAD
            raise ModelFileError(f"{source}: the model uses the plugin {what}, which is not loaded: load it with {hint}")
        record = plugin_record(loaded)
        if record is None or record.sha256 != entry["sha256"]:
            now = "a built-in" if record is None else f"{record.file or record.module}, sha256 {str(record.sha256)[:12]}"
            raise ModelFileError(f"{source}: the plugin {what} has changed since the model was fitted (sha256 "
                                 f"{str(entry['sha256'])[:12]} recorded, loaded: {now}); load the file it was fitted with, or fit again")
