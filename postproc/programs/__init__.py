"""Programs as text and as the toolpath IR: the languages (``dialects``), the IR, the
controller's reading of a program, and writing programs back (``emit``).

The names of ``program_io`` (``postproc.programs.parse_program``, ``emit_texts``,
``write_program`` …, the module ``postproc.programs`` of earlier versions) are lent here on
first use, so that importing ``postproc.programs.ir`` does not load every language.
"""

import importlib

LENT = frozenset({"sniff", "language_of", "parse_program", "with_robot", "emit_texts", "emit_files", "files_for",
                  "refuse_stdout", "refuse_overwrite", "check_texts", "write_set", "write_texts", "write_program"})


def __getattr__(name: str):
    # only the lent names: a submodule's name must fall through to the import system
    if name not in LENT:
        raise AttributeError(f"module 'postproc.programs' has no attribute {name!r}")
    return getattr(importlib.import_module(f"{__name__}.program_io"), name)  # on first use: it loads every language
