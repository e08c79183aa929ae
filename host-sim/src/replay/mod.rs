//! The browser replay (issue 17): one self-contained `replay.html` per run (or per pair of runs
//! for `compare`) that opens from disk with no network. A `<canvas>` 2-D renderer with its own
//! orbit/pan/zoom perspective projection (`replay.js`) draws a 3-D view and a top view of the
//! obstacles, the tube, the UAVs, the cables (coloured by tension against the rated capacity),
//! the load and, on request, the virtual tray's nodes and springs; a time slider, play/pause,
//! speed, live readouts and the faults on a timeline.
//!
//! The data is one inline JSON blob ([`data`]), decimated to the record rate (the record is
//! already sampled at `rates.record_hz`) and rounded to mm and 0.1 N so the 10-UAV paper
//! mission stays well under 5 MB. The page exposes its state (current frame, time, the UAVs'
//! projected pixel positions) in `#vt-state` for the headless-browser test
//! (`tests/replay_browser.rs`); a URL fragment `#t=12.5&paused` picks the time.

pub mod data;

use crate::record::{RunRecord, SceneGeometry};
use std::path::{Path, PathBuf};

/// File name of the replay inside an output directory.
pub const FILE_NAME: &str = "replay.html";

/// Page style, inlined.
const CSS: &str = include_str!("replay.css");
/// Page script (renderer, controls, test hooks), inlined.
const JS: &str = include_str!("replay.js");
/// Page skeleton; `{{TITLE}}`, `{{CSS}}`, `{{DATA}}` and `{{JS}}` are filled in.
const TEMPLATE: &str = include_str!("replay.html");

/// The replay page of `runs` (one run, or two for a comparison) flown in `scene`.
///
/// # Errors
/// The data could not be serialised (text).
pub fn html(scene: &SceneGeometry, runs: &[&RunRecord]) -> Result<String, String> {
    let title = data::title(runs);
    let json = serde_json::to_string(&data::build(scene, runs)).map_err(|e| format!("replay data: {e}"))?;
    // `</` cannot occur outside a JSON string; inside one `<\/` is the same text, and the
    // `<script>` element can then not be closed by the data.
    let json = json.replace("</", "<\\/");
    // Filled in one pass, so text in one part is never taken for a later placeholder.
    let mut out = String::with_capacity(TEMPLATE.len() + CSS.len() + JS.len() + json.len() + title.len());
    let mut rest = TEMPLATE;
    while let Some(start) = rest.find("{{") {
        let (head, tail) = rest.split_at(start);
        out.push_str(head);
        let Some(end) = tail.find("}}") else {
            out.push_str(tail);
            rest = "";
            break;
        };
        match tail.get(2..end) {
            Some("TITLE") => out.push_str(&escape_html(&title)),
            Some("CSS") => out.push_str(CSS),
            Some("DATA") => out.push_str(&json),
            Some("JS") => out.push_str(JS),
            _ => out.push_str(tail.get(..end + 2).unwrap_or_default()),
        }
        rest = tail.get(end + 2..).unwrap_or_default();
    }
    out.push_str(rest);
    Ok(out)
}

/// Writes [`html`] to `dir/replay.html` (the directory is created) and returns the path.
///
/// # Errors
/// Serialisation or I/O errors, as text naming the file.
pub fn write(dir: &Path, scene: &SceneGeometry, runs: &[&RunRecord]) -> Result<PathBuf, String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let path = dir.join(FILE_NAME);
    let page = html(scene, runs)?;
    std::fs::write(&path, page).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(path)
}

/// `text` with `& < > "` escaped for HTML.
fn escape_html(text: &str) -> String {
    let mut s = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => s.push_str("&amp;"),
            '<' => s.push_str("&lt;"),
            '>' => s.push_str("&gt;"),
            '"' => s.push_str("&quot;"),
            c => s.push(c),
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record() -> RunRecord {
        RunRecord {
            scenario: "a </script> b".into(),
            controller: "dissipative".into(),
            f_max_n: 20.0,
            time_s: vec![0.0, 0.05],
            uav_pos_m: vec![vec![[0.0, 1.0, 5.0]], vec![[0.1, 1.0, 5.0]]],
            tension_n: vec![vec![10.0], vec![10.04]],
            load_pos_m: vec![[0.0, 0.0, 2.0], [0.1, 0.0, 2.0]],
            ..RunRecord::default()
        }
    }

    #[test]
    fn page_is_self_contained_and_data_cannot_close_the_script() {
        let rec = record();
        let page = html(&SceneGeometry::default(), &[&rec]).unwrap_or_default();
        assert!(page.starts_with("<!DOCTYPE html>"));
        assert!(!page.contains("{{"), "a placeholder was left unfilled");
        // No network: no external script, style or URL.
        for bad in ["src=\"http", "href=\"http", "<link", "import(", "fetch("] {
            assert!(!page.contains(bad), "page contains {bad}");
        }
        // The only `</script>` are the two closing tags of the data and the script.
        assert_eq!(page.matches("</script>").count(), 2);
        assert!(page.contains("a &lt;/script&gt; b"), "title not escaped");
    }

    #[test]
    fn escape_html_escapes_markup() {
        assert_eq!(escape_html("<a href=\"x\">&</a>"), "&lt;a href=&quot;x&quot;&gt;&amp;&lt;/a&gt;");
    }
}
