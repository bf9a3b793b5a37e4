//! The page around the sections: style, header, navigation, the click-to-enlarge viewer,
//! and the preparation of SVG documents for inline embedding.

use std::fmt::Write as _;

use super::{SECTIONS, esc};

/// The style sheet: figures fill the width of their section up to 960 px (plots) or half of
/// it (pictures without text), so plot text is never shown below its own size on a page
/// of 1100 px or more.
const STYLE: &str = "body{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;\
margin:0;color:#1b2a41;background:#f5f6f8;font-size:15px;line-height:1.45}\
header{background:#1b2a41;color:#fff;padding:18px 32px}header h1{margin:0;font-size:24px}\
header p{margin:4px 0 0;color:#c9d3e3}\
nav{padding:8px 32px;background:#e4e8ef;position:sticky;top:0;z-index:2;display:flex;\
flex-wrap:wrap;gap:2px 16px;font-size:14px}nav a{color:#1b2a41;white-space:nowrap}\
main{padding:0 32px 40px;max-width:1180px}section{background:#fff;margin:18px 0;\
padding:14px 24px;border-radius:6px;box-shadow:0 1px 3px rgba(0,0,0,.12)}\
h2{margin-top:4px;font-size:21px}h3{font-size:17px;margin:22px 0 8px}\
.grid{display:grid;grid-template-columns:repeat(auto-fill,minmax(420px,1fr));gap:14px;\
max-width:1120px}\
figure{margin:10px 0 18px}figure.fig{max-width:960px}figure.half{margin:0}\
figure svg,figure img{display:block;width:100%;height:auto;border:1px solid #dde;\
background:#fff;cursor:zoom-in}\
figure img.px{image-rendering:pixelated}\
figcaption{font-size:14px;color:#445;margin-top:4px}figcaption .src{color:#889;font-size:13px}\
table{border-collapse:collapse;font-size:14px;margin:8px 0;max-width:100%}\
td,th{border:1px solid #ccd;padding:3px 9px;text-align:right;overflow-wrap:anywhere}\
th{background:#eef1f6;vertical-align:bottom}table.kv th,td.l,th.l,td:first-child,th:first-child{text-align:left}\
tr.part td{background:#f6f7fa;text-align:left;font-weight:600}\
.notrun{color:#a33;font-style:italic}.error{color:#fff;background:#a33;padding:4px 8px}.notrun span{color:#888;font-size:13px}\
.note{color:#445;font-size:14px;max-width:960px}\
#viewer{position:fixed;inset:0;background:rgba(20,28,40,.86);display:none;z-index:10;\
align-items:center;justify-content:center;cursor:zoom-out}\
#viewer.open{display:flex}#viewer>*{width:auto;height:auto;max-width:96vw;max-height:94vh;\
background:#fff;border-radius:4px}#viewer svg{width:96vw;height:94vh}";

/// Click (or Enter) on a figure shows a copy of its drawing over the whole window; a click
/// or Escape closes it. No network, no library.
const SCRIPT: &str = "(function(){var v=document.getElementById('viewer');\
function show(f){var d=f.querySelector('svg,img');if(!d)return;var c=d.cloneNode(true);\
c.removeAttribute('width');c.removeAttribute('height');v.replaceChildren(c);\
v.classList.add('open');}\
function hide(){v.classList.remove('open');v.replaceChildren();}\
document.querySelectorAll('figure').forEach(function(f){\
f.addEventListener('click',function(){show(f)});\
f.addEventListener('keydown',function(e){if(e.key==='Enter')show(f)});});\
v.addEventListener('click',hide);\
document.addEventListener('keydown',function(e){if(e.key==='Escape')hide()});})();";

/// Writes the document head, the page header and the navigation.
pub(super) fn head(html: &mut String, scenario: &str, folder: &str) {
    let _ = write!(
        html,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"/>\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\"/>\
         <title>flexstage report: {n}</title><style>{STYLE}</style></head><body>\n\
         <header><h1>flexstage report — scenario “{n}”</h1><p>{}: design → reduce → identify \
         → control, after the scheme of Actuators 2022, 11(7), 179. Every figure is computed \
         from this run folder; click a figure to enlarge it.</p></header>\n<nav>",
        esc(folder),
        n = esc(scenario)
    );
    for s in SECTIONS {
        let _ = write!(html, "<a href=\"#{}\">{}</a>", s.id, esc(s.title));
    }
    html.push_str("</nav>\n<main>\n");
}

/// Closes the page: the figure viewer and its script.
pub(super) fn tail(html: &mut String) {
    let _ = write!(
        html,
        "</main>\n<div id=\"viewer\" role=\"dialog\" aria-label=\"enlarged figure\"></div>\n\
         <script>{SCRIPT}</script>\n</body></html>\n"
    );
}

/// Markup an inline SVG must not contain: scripts, event handlers, embedded HTML, links out.
const UNSAFE: [&str; 8] = [
    "<script",
    "<foreignobject",
    "javascript:",
    "<iframe",
    " on",
    "\ton",
    "href=\"http",
    "<!entity",
];

/// Prepares an SVG document for inline embedding: drops an XML declaration and doctype,
/// replaces the fixed `width`/`height` by `width="100%"` (keeping the `viewBox`, so the
/// drawing scales with the page). `None` for anything that is not a plain drawing with a
/// `viewBox` (the caller then embeds it as an image, where scripts cannot run).
pub(super) fn inline_svg(svg: &str) -> Option<String> {
    let mut s = svg.trim_start();
    for prefix in ["<?xml", "<!DOCTYPE", "<!doctype"] {
        if s.starts_with(prefix) {
            s = s[s.find('>')? + 1..].trim_start();
        }
    }
    if !s.starts_with("<svg") {
        return None;
    }
    let lower = s.to_ascii_lowercase();
    // " on" also matches ordinary text such as "on the"; only attributes are unsafe, so look
    // inside tags only.
    if UNSAFE.iter().any(|u| tag_text(&lower).contains(u)) {
        return None;
    }
    let tag_end = s.find('>')?;
    let attrs = parse_attributes(s[4..tag_end].trim_end_matches('/'))?;
    let get = |n: &str| attrs.iter().find(|(k, _)| k == n).map(|(_, v)| v.as_str());
    let mut tag = String::from("<svg");
    for (k, v) in &attrs {
        if k != "width" && k != "height" {
            let _ = write!(tag, " {k}=\"{v}\"");
        }
    }
    // A drawing without a viewBox would not scale; it is shown as an image instead.
    get("viewBox")?;
    tag.push_str(" width=\"100%\" role=\"img\">");
    Some(format!("{tag}{}", &s[tag_end + 1..]))
}

/// The text inside `<…>` tags of a document (attributes and tag names), tags separated by
/// `>`.
fn tag_text(doc: &str) -> String {
    let mut out = String::new();
    let mut inside = false;
    for c in doc.chars() {
        match c {
            '<' => {
                inside = true;
                out.push('<');
            }
            '>' => {
                inside = false;
                out.push('>');
            }
            c if inside => out.push(c),
            _ => {}
        }
    }
    out
}

/// `name="value"` pairs of a start tag's attribute text; `None` when malformed.
fn parse_attributes(text: &str) -> Option<Vec<(String, String)>> {
    let mut out = Vec::new();
    let mut rest = text.trim_start();
    while !rest.is_empty() {
        let eq = rest.find('=')?;
        let name = rest[..eq].trim().to_string();
        let after = rest[eq + 1..].trim_start();
        let quote = after.chars().next()?;
        if quote != '"' && quote != '\'' {
            return None;
        }
        let close = after[1..].find(quote)?;
        out.push((name, after[1..1 + close].to_string()));
        rest = after[close + 2..].trim_start();
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plotters_and_outline_svgs_are_inlined_scalable() {
        let plot = "<svg width=\"800\" height=\"500\" viewBox=\"0 0 800 500\" \
                    xmlns=\"http://www.w3.org/2000/svg\">\n<text>on the left</text></svg>";
        let s = inline_svg(plot).unwrap();
        assert!(s.starts_with(
            "<svg viewBox=\"0 0 800 500\" xmlns=\"http://www.w3.org/2000/svg\" width=\"100%\""
        ));
        assert!(s.contains("on the left"), "text is not an event handler");
        let no_view_box =
            "<?xml version=\"1.0\"?>\n<svg width=\"320\" height=\"200\"><path/></svg>";
        assert!(inline_svg(no_view_box).is_none(), "shown as an image");
    }

    #[test]
    fn scripts_and_handlers_are_not_inlined() {
        for bad in [
            "<svg viewBox=\"0 0 1 1\"><script>alert(1)</script></svg>",
            "<svg viewBox=\"0 0 1 1\" onload=\"alert(1)\"></svg>",
            "<svg viewBox=\"0 0 1 1\"><a href=\"http://x\"/></svg>",
            "<html><svg/></html>",
            "<svg width=\"1\"></svg>",
        ] {
            assert!(inline_svg(bad).is_none(), "{bad}");
        }
    }
}
