"""The demo's report: one self-contained HTML page (images as base64 data URIs) from the stages' outputs."""

from __future__ import annotations

import base64
import html
import json
from pathlib import Path

from .evaluate import gain_text, mean_std_text

CELL_PX = 112  # displayed width of one contact-sheet cell


def data_uri(path: Path) -> str:
    """A PNG file as a data URI."""
    return "data:image/png;base64," + base64.b64encode(Path(path).read_bytes()).decode("ascii")


def metrics_table(summary: dict) -> str:
    """Per method: transfer PSNR, gain over the mean preset (± its standard error), SSIM, ms per reference."""
    rows = "".join(
        f"<tr><td>{html.escape(name)}</td><td>{mean_std_text(s['psnr'], 2)}</td><td>{gain_text(s)}</td>"
        f"<td>{mean_std_text(s['ssim'], 4)}</td><td>{s['ms_per_reference']:.1f}</td></tr>"
        for name, s in summary.items())
    return ('<table id="metrics"><tr><th>method</th><th>transfer PSNR dB</th><th>gain over mean preset dB</th>'
            f"<th>SSIM</th><th>ms per reference</th></tr>{rows}</table>")


def errors_table(spec: list[str], summary: dict) -> str:
    """Mean absolute parameter error (fraction of each range) per parameter and method."""
    head = "".join(f"<th>{html.escape(m)}</th>" for m in summary)
    rows = "".join(f"<tr><td>{p}</td>" + "".join(f"<td>{s['param_error'][p]:.3f}</td>" for s in summary.values())
                   + "</tr>" for p in spec)
    return f'<table id="param-errors"><tr><th>parameter</th>{head}</tr>{rows}</table>'


def timings_table(timings: list[dict]) -> str:
    """Wall time of each stage: measured in this run, or recorded when a reused stage was made."""
    rows = "".join(f"<tr><td>{i}. {html.escape(t['stage'])}</td><td>{t['seconds']:.1f}</td>"
                   f"<td>{'reused (time when made)' if t['reused'] else 'this run'}</td></tr>"
                   for i, t in enumerate(timings, 1))
    total = sum(t["seconds"] for t in timings)
    return (f'<table id="timings"><tr><th>stage</th><th>wall s</th><th></th></tr>{rows}'
            f"<tr><th>total</th><th>{total:.1f}</th><th>{total / 60:.1f} min</th></tr></table>")


def sheet(results: dict, path: Path) -> str:
    """The contact sheet with its column labels: reference on A | truth on B | each method's estimate on B."""
    columns = results["sheet_columns"]
    labels = "".join(f'<div style="width:{CELL_PX}px">{html.escape(c)}</div>' for c in columns)
    return (f'<div class="labels">{labels}</div><img class="sheet" alt="contact sheet" src="{data_uri(path)}" '
            f'style="width:{CELL_PX * len(columns)}px">')


def verdict(summary: dict) -> str:
    """One sentence: the encoder against the two preset baselines."""
    encoder, nearest = summary["encoder"], summary["nearest preset"]
    return (f"The encoder's transfer PSNR is {encoder['gain_over_mean_preset_db']:+.2f} dB over the mean preset "
            f"(nearest preset: {nearest['gain_over_mean_preset_db']:+.2f} dB, which renders every preset on the "
            f"reference's source: {nearest['ms_per_reference']:.0f} ms against {encoder['ms_per_reference']:.1f} ms).")


STYLE = """body{font-family:sans-serif;max-width:1100px;margin:2em auto;color:#222}
table{border-collapse:collapse;margin:.6em 0}td,th{border:1px solid #ccc;padding:3px 8px;font-size:13px}
.labels{display:flex;font-size:11px}.labels div{text-align:center}
img.sheet{image-rendering:pixelated}pre{background:#f4f4f4;padding:8px;font-size:12px;overflow-x:auto}
.plots img{max-width:100%}"""


def write_report(out: Path, context: dict) -> Path:
    """DIR/report/index.html (and summary.json beside it); returns the page."""
    eval_dir, runs = out / "eval", out / "runs"
    results = json.loads((eval_dir / "results.json").read_text())
    summary, size = results["summary"], context["settings"]
    title = f"vto demo: {context['renderer']} ({context['size']})"
    figures = [("Imitator losses", runs / "imitator" / "losses.png"),
               ("Encoder losses", runs / "encoder" / "losses.png"),
               ("Transfer PSNR per method", eval_dir / "psnr.png"), ("Parameter errors", eval_dir / "errors.png")]
    plots = "".join(f'<h3>{name}</h3><img alt="{name}" src="{data_uri(path)}">' for name, path in figures
                    if path.is_file())
    commands = html.escape("\n".join(context["commands"]))
    head = f'<meta charset="utf-8"><title>{title}</title><style>{STYLE}</style>'
    page = f"""<!DOCTYPE html><html><head>{head}</head><body>
<h1>{title}</h1>
<p>Kips et al. 2022 on the default {context['renderer']} scene: a dataset with sensitivity renders trains the imitator,
a larger one the encoder (graphics loss + rendering loss through the frozen imitator); the exported ONNX encoder is
evaluated on {size.eval_n} fresh looks (paper 7.2.1: estimated from a render on source A, compared on source B).
Parameters: {', '.join(context['spec'])}. Renders: {size.res} px, {size.samples} spp.</p>
<p><b>{html.escape(verdict(summary))}</b></p>
<h2>Metrics</h2>{metrics_table(summary)}
<p>{html.escape(context['shipped_note'])} {html.escape(results['perceptual'])}.</p>
<h2>Contact sheet</h2><p>Per row: the reference on source A, the truth on source B, then each method's estimate
rendered on B.</p>{sheet(results, eval_dir / 'sheet.png')}
<h2>Mean absolute parameter error (fraction of range)</h2>{errors_table(context['spec'], summary)}
<h2>Stage wall times</h2>{timings_table(context['timings'])}
<div class="plots">{plots}</div>
<h2>The stages as commands</h2><pre>{commands}</pre>
</body></html>
"""
    folder = out / "report"
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "index.html"
    path.write_text(page)
    (folder / "summary.json").write_text(json.dumps({
        "renderer": context["renderer"], "size": context["size"], "timings": context["timings"],
        "psnr": {m: s["psnr"][0] for m, s in summary.items()},
        "gain_over_mean_preset_db": {m: s["gain_over_mean_preset_db"] for m, s in summary.items()}}, indent=1))
    return path
