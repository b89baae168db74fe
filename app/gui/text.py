"""The viser GUI's Markdown texts; user strings in them are shown as text, never as markup.

viser renders ``add_markdown`` content as Markdown with HTML, so a CSV header, a file
name or an error message that quotes a cell could draw an image or a link. Every such
string goes through :func:`md_text` first. The other functions write the GUI's summaries
(model, inverse, digitized state, recording, diagnosis) from computed results.
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING

import numpy as np

from app.services.analysis.recordings import Recording
from app.services.explore.simulation import Result, operator_count, pi_part, weight_note
from app.services.words import model_words

if TYPE_CHECKING:
    from app.services.analysis.diagnosis import SessionDiagnosis

__all__ = ["diagnosis_markdown", "inverse_markdown", "md_text", "model_markdown",
           "recording_markdown", "state_markdown"]

_HTML = {"&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;", "'": "&#39;"}
_MD = re.compile(r"([\\`*_{}\[\]()#+\-.!|~])")
#: Where GitHub-flavoured Markdown (viser's renderer) would start a link in plain text: a
#: scheme (``https://``, ``mailto:``), ``www.`` and the ``@`` of an address.
_AUTOLINK = re.compile(r"(?i)(https?|ftp|mailto|xmpp|www)(?=[:.])|(@)")
#: An invisible character that breaks those patterns (U+2060 WORD JOINER: no width, no break).
_JOIN = "\u2060"


def md_text(value: object) -> str:
    """``value`` as literal text for a Markdown element (HTML and Markdown escaped, and a
    bare URL or e-mail address kept from becoming a link by an invisible word joiner).

    Examples
    --------
    >>> md_text("<img src=x onerror=alert(1)>")
    '&lt;img src=x onerror=alert\\\\(1\\\\)&gt;'
    """
    s = _AUTOLINK.sub(lambda m: m.group(0) + _JOIN, str(value))  # a bare URL stays text
    s = _MD.sub(r"\\\1", s)
    return "".join(_HTML.get(c, c) for c in s)


def model_markdown(res: Result) -> str:
    """Type, operator count, slopes and maximum loop width of ``res``'s model."""
    m = res.model
    n = operator_count(m)  # a GPI's plays too; a memoryless map has none
    lines = [f"**{md_text(model_words(m))}**" + ("" if n is None else f", {n} operators")]
    if pi_part(m) is m:  # a classical PI itself
        lines.append("slopes " + ", ".join(f"{s:.3g}" for s in m.slopes))
        lines.append(f"max loop width σ = {m.max_loop_width:.4g}")
    note = weight_note(m)
    if note:
        lines.append(f"ℹ️ {md_text(note)}")
    text = "  \n".join(lines)
    if res.inverse_error:
        text += f"  \n⚠️ {md_text(res.inverse_error)}"
    return text


def inverse_markdown(res: Result, no_inverse: str | None) -> str:
    """The inverse view's summary: why there is no inverse (``no_inverse``), else its
    tracking error and clipping, else a pointer to the view."""
    if no_inverse:
        return f"⚠️ **No inverse:** {md_text(no_inverse)}"
    if res.y_comp is None:
        return "*choose the Inverse view to compute the compensation*"
    err = res.y_comp - res.u
    text = f"RMS tracking error {np.sqrt(np.mean(err**2)):.4g}, max {np.max(np.abs(err)):.4g}"
    if res.inverse_warning:
        text += (f"  \n⚠️ **The inverse clipped part of the input:** "
                 f"{md_text(res.inverse_warning)}")
    return text


def state_markdown(res: Result, k: int) -> str:
    """State ``k`` of ``res``'s digitized trace: time, digit row, state point, ``H``."""
    d = res.digitized
    tr = d.trace
    row = " ".join(str(int(b)) for b in tr.digits[k][::-1])
    H = d.H  # noqa: N806 - the paper's name
    fmt = lambda a: " ".join(f"{v:.3g}" for v in a)  # noqa: E731
    return (
        f"**State {k}/{len(tr.sample) - 1}** at t = {res.t[tr.sample[k]]:.3f} s  \n"
        f"digits b{d.model.n}…b1: `{row}`  \n"
        f"state point (X, Y) = ({tr.x_b[k]:.4g}, {tr.y_b[k]:.4g})  \n"
        f"H: Δx = [{fmt(H[0])}], Δy = [{fmt(H[1])}]  \n"
        f"H⁻¹ swaps the rows (Δx ↔ Δy)  \n"
        f"max |digitized − classical| = {np.max(np.abs(d.y - d.y_classical)):.3g}"
    )


def recording_markdown(rec: Recording, rows: int = 5) -> str:
    """Name, length and the first ``rows`` samples of a recording, with its units."""
    head = "\n".join(f"| {a:.4g} | {b:.4g} | {c:.4g} |"
                     for a, b, c in zip(rec.t[:rows], rec.u[:rows], rec.y[:rows], strict=True))
    return (
        f"✅ **{md_text(rec.name)}**: {rec.n_samples} samples, "
        f"t = {rec.t[0]:.4g}…{rec.t[-1]:.4g} s\n\n"
        f"| t [{md_text(rec.units.get('time') or 's')}] "
        f"| u [{md_text(rec.units.get('input') or 'a.u.')}] "
        f"| y [{md_text(rec.units.get('output') or 'a.u.')}] |\n|---|---|---|\n{head}"
    )


def diagnosis_markdown(diag: SessionDiagnosis) -> str:
    """A diagnosis job's result as Markdown: its findings, sentences with units written for
    people (:func:`app.services.analysis.diagnosis.diagnosis_summary`)."""
    lines = ["### Diagnosis", ""]
    for f in diag.summary.findings:
        lines.append(f"- {md_text(f)}")
    return "\n".join(lines)
