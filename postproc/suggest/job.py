"""One suggest-poses job's outputs: the chosen-poses CSV, the robot program that visits
them and the curve figure, built in memory and written together or not at all; and the
report's text."""

from __future__ import annotations

from pathlib import Path

from postproc.files import write_all

from . import CRITERION_NAMES, Suggestion
from .candidates import Candidates, chosen_csv
from .figure import curve_png
from .program import check_program, language_of, program_paths, visiting_program


def write_outputs(suggestion: Suggestion, cands: Candidates, output: Path, program_out: Path | None = None,
                  program_language: str | None = None, plot: Path | None = None, title: str = "") -> list[Path]:
    """Write CHOSEN.csv (and the program's files, the figure); returns every path written."""
    files: dict[Path, bytes] = {Path(output): chosen_csv(cands, suggestion.chosen).encode("utf-8")}
    if program_out is not None:
        language = language_of(program_out, program_language)
        paths = program_paths(language, program_out)
        q = cands.q_deg[suggestion.chosen]
        texts = visiting_program(language, Path(program_out).stem, q, suggestion.ids)
        check_program(language, paths, texts, q)
        files.update({p: t.encode("latin-1") for p, t in zip(paths, texts)})
    if plot is not None:
        files[Path(plot)] = curve_png(suggestion, title)
    write_all(files)
    return list(files)


def report_lines(s: Suggestion, names_shown: int = 60) -> list[str]:
    """The terminal report: criterion, predicted error against random, standard errors, condition number, curve."""
    n = len(s.chosen)
    lines = [f"{n} poses chosen ({s.n_random} of them at random, the exchange replaced {s.swaps} of the greedy search's), criterion {CRITERION_NAMES[s.criterion]}",
             f"expected model error RMS at {s.where}: {s.expected_rms_mm:.4f} mm (random {n} poses: {s.random_rms_mm:.4f} mm; "
             + (f"random selection needs about {s.random_equivalent_n} poses for the same)" if s.random_equivalent_n is not None
                else "random selection needs more poses than the curve spans for the same)"),
             *([f"no design of {n} distinct poses from these candidates can predict better at {s.where} than {s.bound_rms_mm:.4f} mm "
                f"(the I-optimal bound for distinct poses; this design is {100 * (s.expected_rms_mm / s.bound_rms_mm - 1):.0f} % above it)"] if s.bound_rms_mm else []),
             f"condition number of the identification Jacobian (columns in typical sizes): {s.condition_number:.4g}",
             "expected standard error of each identified parameter (measurement noise only):"]
    for name, std in list(s.std.items())[:names_shown]:
        lines.append(f"  {name}: {std:.3g} {s.units[name]}")
    if len(s.std) > names_shown:
        lines.append(f"  ... {len(s.std) - names_shown} more (--json lists them all)")
    if s.fixed:
        lines.append(f"not identifiable from these candidates ({len(s.fixed)} parameters; fit fixes them too):")
        lines.extend(f"  {name}: {why}" for name, why in s.fixed.items())
    lines.append("predicted error RMS (mm) against N:  N  suggested  random")
    lines.extend(f"  {k:5d}  {'   -   ' if sug != sug else f'{sug:.4f}'}  {r:.4f}" for k, sug, r in s.curve)
    lines.extend(f"note: {note}" for note in s.notes)
    return lines
