"""One self-contained HTML page (charts embedded as base64 PNG, tables from
the markdown written beside them) for the benchmark scripts' results."""
import base64
import html
import os


def _markdown_to_html(text):
    """Pipe tables become <table>; other lines become paragraphs or headings."""
    out, table = [], []

    def flush():
        if table:
            rows = [r for r in table if not set(r.replace("|", "").strip()) <= set("-: ")]
            cells = [[html.escape(c.strip()) for c in r.strip().strip("|").split("|")] for r in rows]
            out.append("<table><tr>" + "".join(f"<th>{c}</th>" for c in cells[0]) + "</tr>" +
                       "".join("<tr>" + "".join(f"<td>{c}</td>" for c in r) + "</tr>" for r in cells[1:]) + "</table>")
            table.clear()

    for line in text.splitlines():
        if line.strip().startswith("|"):
            table.append(line)
            continue
        flush()
        if line.startswith("#"):
            level = min(len(line) - len(line.lstrip("#")) + 1, 4)
            out.append(f"<h{level}>{html.escape(line.lstrip('#').strip())}</h{level}>")
        elif line.strip():
            out.append(f"<p>{html.escape(line)}</p>")
    flush()
    return "\n".join(out)


def write_html(path, title, markdown_paths=(), png_paths=()):
    parts = []
    for png in png_paths:
        if os.path.exists(png):
            data = base64.b64encode(open(png, "rb").read()).decode("ascii")
            parts.append(f'<figure><img src="data:image/png;base64,{data}" alt="{html.escape(os.path.basename(png))}">'
                         f"<figcaption>{html.escape(os.path.basename(png))}</figcaption></figure>")
    for md in markdown_paths:
        if os.path.exists(md):
            parts.append(_markdown_to_html(open(md).read()))
    page = ("<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>" + html.escape(title) + "</title>"
            "<style>body{font-family:sans-serif;margin:2em;max-width:1200px}img{max-width:100%}"
            "table{border-collapse:collapse}td,th{border:1px solid #bbb;padding:2px 8px}</style></head><body>"
            f"<h1>{html.escape(title)}</h1>\n" + "\n".join(parts) + "\n</body></html>\n")
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        f.write(page)
    os.replace(tmp, path)
