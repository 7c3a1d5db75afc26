"""A self-contained HTML report: figures embedded as PNG, tables, findings in plain words."""

from __future__ import annotations

import base64
import html
import io

import matplotlib.pyplot as plt
import numpy as np

from postproc.model.diagnose import grouped_findings
from postproc.model.identify import Stats, nominal_model, residuals
from postproc.model.structure import smooth_fit
from postproc.robot import kinematics as kin

from . import figures
from .partial_residual import partial_residual


def _png(fig) -> str:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    return base64.b64encode(buf.getvalue()).decode()


def _img(fig, alt: str) -> str:
    return f'<figure><img alt="{html.escape(alt)}" src="data:image/png;base64,{_png(fig)}"/><figcaption>{html.escape(alt)}</figcaption></figure>'


CSS = """
body { font-family: system-ui, sans-serif; max-width: 1200px; margin: 2em auto; color: #222; }
h1 { font-size: 1.6em; } h2 { margin-top: 1.6em; border-bottom: 1px solid #ddd; }
table { border-collapse: collapse; margin: 0.8em 0; } td, th { border: 1px solid #ccc; padding: 4px 10px; text-align: right; }
th { background: #f3f3f3; } td.l, th.l { text-align: left; }
tr.sig td { background: #eaf7ea; } .finding { background: #fff8e1; padding: 0.6em 1em; border-left: 4px solid #f0b400; margin: 0.4em 0; }
code.cmd { background: #f4f4f4; padding: 1px 4px; white-space: pre-wrap; word-break: break-all; }
figure { margin: 1em 0; } img { max-width: 100%; } figcaption { color: #555; font-size: 0.9em; }
"""


def _nominal_stats(model, meas):
    """The nominal robot's error as ``postproc fit``, ``simulate`` and ``ladder`` print it:
    rigidly registered onto the data (6-DOF best fit), whatever the model's effects."""

    return Stats.of(residuals(nominal_model(model.robot, model.tool_mm, meas, registered=True), meas))


def _findings(findings) -> str:
    """The findings' words, each group followed once by the command that acts on it, ready to copy."""

    parts = []
    for texts, command in grouped_findings(findings):
        words = "<br/>".join(html.escape(text) for text in texts)
        run = f"<br/>Run: <code class='cmd'>{html.escape(command)}</code>" if command else ""
        parts.append(f"<div class='finding'>{words}{run}</div>")
    return "".join(parts)


def diagnosis_report(model, meas, diagnosis, ladder_rows=None, title: str | None = None) -> str:
    """The report of ``postproc diagnose --report``."""
    nominal = kin.fk(model.robot, meas.q_deg, tool=model.tool_mm)[:, :3, 3]
    # Errors relative to the nominal robot, all in the measurement frame.
    rot, trans = model.base_transform()
    nominal_meas = nominal @ rot.T + trans
    measured_err = meas.measured_mm - nominal_meas
    predicted = meas.measured_mm - diagnosis.residual_mm
    model_err = predicted - nominal_meas
    st = diagnosis.stats
    parts = [f"<!doctype html><html><head><meta charset='utf-8'><title>{html.escape(title or 'postproc diagnosis')}</title><style>{CSS}</style></head><body>"]
    parts.append(f"<h1>{html.escape(title or 'Diagnosis')}</h1>")
    parts.append(f"<p>Robot <b>{html.escape(model.robot.name)}</b>, tool {model.tool_mm.tolist()} mm, model effects <code>{html.escape(model.effects.spec())}</code>; {st.n} poses from <code>{html.escape(meas.source)}</code>.</p>")
    if len(model.effects):
        # Each effect's own plain-language description (postproc.model.effects: Effect.summary).
        parts.append("<ul>" + "".join(f"<li><code>{html.escape(e.spec())}</code>: {html.escape(e.summary)}</li>" for e in model.effects) + "</ul>")
    parts.append("<h2>What to do</h2>")
    parts.append(_findings(diagnosis.findings))
    parts.append("<h2>Compare</h2><table><tr><th class='l'></th><th>RMS (mm)</th><th>mean (mm)</th><th>max (mm)</th><th>RMS x</th><th>RMS y</th><th>RMS z</th></tr>")
    nominal_st = _nominal_stats(model, meas)
    parts.append(f"<tr><td class='l'>nominal robot{' (registered onto the data)' if model.effects.of_kind('base') else ''}</td><td>{nominal_st.rms_mm:.4f}</td><td>{nominal_st.mean_mm:.4f}</td><td>{nominal_st.max_mm:.4f}</td>" + "".join(f"<td>{v:.4f}</td>" for v in nominal_st.rms_axis_mm) + "</tr>")
    parts.append(f"<tr><td class='l'>model on this set</td><td>{st.rms_mm:.4f}</td><td>{st.mean_mm:.4f}</td><td>{st.max_mm:.4f}</td>" + "".join(f"<td>{v:.4f}</td>" for v in st.rms_axis_mm) + "</tr>")
    parts.append(f"<tr><td class='l'>cross-validated (model refitted)</td><td>{diagnosis.cv_rms_mm:.4f}</td><td colspan='5' class='l'>noise floor {diagnosis.noise_floor_mm:.4f} mm ({diagnosis.cv_rms_mm / diagnosis.noise_floor_mm:.2f} x)</td></tr></table>")
    parts.append(_img(figures.histograms(np.linalg.norm(measured_err, axis=1), np.linalg.norm(diagnosis.residual_mm, axis=1)), "3-D position error of the nominal robot and of the model on this set."))
    parts.append(_img(figures.error_vectors(nominal, measured_err, model_err, diagnosis.residual_mm), "Error vectors at each measured pose: what was measured (grey), what the model predicts (blue), what is left (red)."))
    parts.append("<h2>Where it fails</h2><table><tr><th class='l'>variable</th><th>share of residual variance</th><th>p (Holm)</th><th>largest bin mean (mm)</th><th class='l'>verdict</th></tr>")
    for b in diagnosis.breakdowns:
        biggest = float(np.abs(np.array(b.mean_mm)).max())
        verdict = "structure" if b.significant else "noise"
        parts.append(f"<tr class='{'sig' if b.significant else ''}'><td class='l'>{html.escape(b.label)}</td><td>{100 * b.eta2:.1f}%</td><td>{b.p_adjusted:.1e}</td><td>{biggest:.4f}</td><td class='l'>{verdict}</td></tr>")
    parts.append("</table>")
    parts.append(_img(figures.residual_vs_variables(diagnosis.breakdowns, diagnosis.variables, diagnosis.residual_mm), "Residual against each variable; lines are binned means, red titles: the residual follows the variable (Holm-corrected test)."))
    parts.extend(_follows_section(diagnosis))
    parts.append("<h2>What is missing</h2>")
    if diagnosis.candidates:
        parts.append("<p>Recommended only when it brings the cross-validated RMS at least 20% of the way to the noise floor in at least 80% of bootstrap resamples.</p>")
        parts.append("<table><tr><th class='l'>candidate effect</th><th>explained (held out)</th><th>CV RMS if added (mm)</th><th>way to floor</th><th>stability</th><th>p (Holm)</th><th class='l'>in plain words</th></tr>")
        for c in list(diagnosis.candidates) + ([diagnosis.combination] if diagnosis.combination is not None else []):
            parts.append(f"<tr class='{'sig' if c.significant else ''}'><td class='l'><code>{html.escape(c.effect)}</code></td><td>{100 * c.explained:.1f}%</td><td>{c.rms_if_added_mm:.4f}</td>"
                         f"<td>{100 * c.progress:.0f}%</td><td>{100 * c.stability:.0f}%</td><td>{c.p_adjusted:.1e}</td><td class='l'>{html.escape(c.message)}</td></tr>")
        parts.append("</table>")
        parts.append(_img(figures.candidates_chart(list(diagnosis.candidates), diagnosis.cv_rms_mm, diagnosis.noise_floor_mm), "Cross-validated RMS with each candidate added."))
    else:
        parts.append("<p>Every catalog effect the data's columns allow is already in the model.</p>")
    if ladder_rows:
        parts.append("<h2>Ladder</h2>" + ladder_table(ladder_rows))
        parts.append(_img(figures.ladder_chart(ladder_rows, diagnosis.noise_floor_mm), "Error per step: each step adds one effect."))
    parts.append("</body></html>")
    return "\n".join(parts)


def _follows_section(diagnosis) -> list[str]:
    """What the residual follows: the strongest variables and pairs, and the partial-residual
    plot of the one the verdict names."""
    shown = [st for st in diagnosis.structure if st.significant][:8]
    if not shown:
        return ["<h2>What the residual follows</h2><p>No variable, alone or in pairs, beyond chance.</p>"]
    out = ["<h2>What the residual follows</h2><table><tr><th class='l'>variable(s)</th><th>explained by a smooth function (held out)</th><th>p (Holm)</th></tr>"]
    out.extend(f"<tr><td class='l'><code>{html.escape(st.name)}</code></td><td>{100 * st.explained:.1f}%</td><td>{st.p_adjusted:.1e}</td></tr>" for st in shown)
    out.append("</table>")
    if diagnosis.follows is not None:
        fitted = smooth_fit(diagnosis.variables, diagnosis.follows.variables, diagnosis.residual_mm)
        out.append(_img(partial_residual(diagnosis.variables, diagnosis.follows, diagnosis.residual_mm, fitted),
                        f"Partial residual: the residual against {diagnosis.follows.name}, with the smooth function of them."))
    return out


def ladder_table(rows) -> str:
    has_val = "val_rms_mm" in rows[0]
    out = ["<table><tr><th>step</th><th class='l'>added</th><th>train RMS (mm)</th><th>CV RMS (mm)</th>" + ("<th>validation RMS (mm)</th>" if has_val else "") + "</tr>"]
    for r in rows:
        out.append(f"<tr><td>{r['step']}</td><td class='l'><code>{html.escape(r['added'])}</code></td><td>{r['train_rms_mm']:.4f}</td><td>{r['cv_rms_mm']:.4f}</td>" + (f"<td>{r['val_rms_mm']:.4f}</td>" if has_val else "") + "</tr>")
    out.append("</table>")
    return "".join(out)


def ladder_report(rows, floor_mm: float, title: str) -> str:
    body = ladder_table(rows) + _img(figures.ladder_chart(rows, floor_mm), "Error per step: each step adds one effect.")
    return f"<!doctype html><html><head><meta charset='utf-8'><title>{html.escape(title)}</title><style>{CSS}</style></head><body><h1>{html.escape(title)}</h1>{body}</body></html>"
