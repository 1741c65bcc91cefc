//! `report.html`: one self-contained page (no network, no script) with the summary tables, the
//! plots as inline SVG and the difference heat maps as inline PNG.

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::{Context, Result};
use base64::Engine;

use crate::diff_maps::DiffMap;
use crate::table::Table;

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// A table cell: numbers right-aligned, text left; Markdown's `code` spans become <code>.
fn cell(s: &str) -> String {
    if s.parse::<f64>().is_ok() {
        return format!("<td class=\"n\">{s}</td>");
    }
    match s.strip_prefix('`').and_then(|s| s.strip_suffix('`')) {
        Some(code) => format!("<td><code>{}</code></td>", escape(code)),
        None => format!("<td>{}</td>", escape(s)),
    }
}

fn table(t: &Table) -> String {
    // A folded table opens on a click (<details>: no script needed).
    let (open, close) = if t.folded {
        (
            format!(
                "<details class=\"table\"><summary><h2>{}</h2> ({} columns: show)</summary>",
                escape(&t.title),
                t.header.len()
            ),
            "</details>\n",
        )
    } else {
        (
            format!("<section class=\"table\"><h2>{}</h2>", escape(&t.title)),
            "</section>\n",
        )
    };
    let mut s = format!("{open}<p>{}</p><table><thead><tr>", escape(&t.note));
    for h in &t.header {
        s += &format!("<th>{}</th>", escape(h));
    }
    s += "</tr></thead><tbody>";
    for r in &t.rows {
        s += "<tr>";
        for c in r {
            s += &cell(c);
        }
        s += "</tr>";
    }
    s + "</tbody></table>" + close
}

/// The colour scale of a difference image: blue at -scale, white at 0, red at +scale.
fn scale_legend(scale: f32) -> String {
    format!(
        "<div class=\"scale\"><span>-{scale:.0}</span><span class=\"bar\"></span>\
         <span>+{scale:.0}</span></div>"
    )
}

fn diff_section(diffs: &[DiffMap], out: &Path) -> Result<String> {
    if diffs.is_empty() {
        return Ok(String::new());
    }
    let mut labels: Vec<&str> = Vec::new();
    let mut by_frame: BTreeMap<i32, Vec<usize>> = BTreeMap::new();
    for (i, m) in diffs.iter().enumerate() {
        if !labels.contains(&m.label.as_str()) {
            labels.push(&m.label);
        }
        by_frame.entry(m.frame).or_default().push(i);
    }
    let mut s = String::from(
        "<section id=\"differences\"><h2>Difference heat maps</h2><p>Per pixel, the method's \
         shadow-ray node visits (N_B, summed over lights and samples) minus the baseline's: blue \
         where the method does less work, red where it does more, white where they agree. Each \
         image's scale is under it, in node visits per pixel.</p><table class=\"diffs\"><thead>\
         <tr><th>frame</th>",
    );
    for l in &labels {
        s += &format!("<th>{}</th>", escape(l));
    }
    s += "</tr></thead><tbody>";
    let engine = base64::engine::general_purpose::STANDARD;
    for (frame, maps) in by_frame {
        s += &format!("<tr><td>{frame}</td>");
        for l in &labels {
            s += "<td>";
            if let Some(m) = maps.iter().map(|&i| &diffs[i]).find(|m| m.label == *l) {
                let path = out.join(&m.file);
                let png = std::fs::read(&path).with_context(|| format!("{}", path.display()))?;
                s += &format!(
                    "<img class=\"diff\" alt=\"{} frame {frame}\" src=\"data:image/png;base64,{}\">{}\
                     <div class=\"total\">sum {:+.0}</div>",
                    escape(l),
                    engine.encode(png),
                    scale_legend(m.scale),
                    m.total
                );
            }
            s += "</td>";
        }
        s += "</tr>";
    }
    Ok(s + "</tbody></table></section>\n")
}

const STYLE: &str = "body{font-family:sans-serif;margin:2em;max-width:1400px;color:#222}\
table{border-collapse:collapse;margin:1em 0}th,td{border:1px solid #ccc;padding:3px 8px;\
text-align:left}td.n{text-align:right}th{background:#f0f0f0}\
figure{margin:1.5em 0}figcaption{font-size:90%;color:#555}img.diff{image-rendering:pixelated;\
width:256px;display:block}.scale{display:flex;align-items:center;gap:4px;font-size:80%}\
.scale .bar{display:inline-block;width:160px;height:10px;background:linear-gradient(to right,\
rgb(59,76,192),rgb(247,247,247),rgb(180,4,38))}.total{font-size:80%;color:#555}code{font-size:90%}\
#answer{background:#eef6ee;border-left:4px solid #3a8a3a;padding:0.2em 1em;margin:1em 0}\
details.table summary{cursor:pointer;margin:1em 0}details.table summary h2{display:inline}";

pub fn page(
    heading: &str,
    answer: &[String],
    verdict: &str,
    tables: &[Table],
    plots: &[(String, String, String)],
    diffs: &[DiffMap],
    out: &Path,
) -> Result<String> {
    let mut s = format!(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{}</title>\
         <style>{STYLE}</style></head><body>\n<h1>{}</h1>\n",
        escape(heading),
        escape(heading),
    );
    if !answer.is_empty() {
        s += "<section id=\"answer\"><h2>What to use</h2>";
        for sentence in answer {
            s += &format!("<p>{}</p>", escape(sentence));
        }
        s += "</section>\n";
    }
    s += &format!("<p id=\"verdict\">{}</p>\n", escape(verdict));
    for t in tables {
        s += &table(t);
    }
    s += "<section id=\"plots\"><h2>Plots</h2>";
    for (name, caption, svg) in plots {
        s += &format!(
            "<figure id=\"plot-{}\">{}<figcaption>{}</figcaption></figure>\n",
            escape(name),
            svg,
            escape(caption)
        );
    }
    s += "</section>\n";
    s += &diff_section(diffs, out)?;
    s += "</body></html>\n";
    Ok(s)
}
