"""Shared parsing machinery: the number scanner, line shapes, lark loading and the IR builder (the languages live in postproc.programs.dialects)."""
