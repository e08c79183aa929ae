//! The browser replay (issue 17) in a real browser: headless Chromium opens the `replay.html` of
//! a real flight (the 3-UAV experiment) from disk, with the network switched off, and
//!   - the page loads with no console message and no script error;
//!   - the animation advances (the page publishes its current frame in `#vt-state`);
//!   - a screenshot at a chosen time is not blank, and at each UAV's projected position (which
//!     the page also publishes) the pixel is that UAV's colour, not the background.
//!
//! Without Chromium the test prints why and passes vacuously, unless `VT_REQUIRE_CHROMIUM=1`
//! (set by `scripts/test-all.sh`, which installs Debian's `chromium`): then it fails.

use host_sim::sim::{self, RunOptions};
use host_sim::{replay, scenario};
use std::path::{Path, PathBuf};
use std::process::Command;

/// Window size of the DOM runs, CSS pixels; device pixel ratio 1. Headless Chromium gives a
/// `--dump-dom` page a smaller viewport than the window (and a `--screenshot` page the whole
/// window), so the screenshot is taken at the viewport the DOM run reported.
const WINDOW: (u32, u32) = (1400, 1000);
/// Time the screenshot shows, s (mid-flight, the formation in the winding section).
const SHOT_T_S: f64 = 20.0;

fn chromium() -> Option<PathBuf> {
    let required = std::env::var_os("VT_REQUIRE_CHROMIUM").is_some_and(|v| v == "1");
    let found = ["chromium", "chromium-browser", "google-chrome"].iter().find_map(|name| {
        std::env::split_paths(&std::env::var_os("PATH").unwrap_or_default())
            .map(|d| d.join(name))
            .find(|p| p.is_file())
    });
    if found.is_none() {
        assert!(!required, "chromium not found and VT_REQUIRE_CHROMIUM=1: install it (apt-get install -y chromium)");
        eprintln!("SKIPPED: chromium not found (apt-get install -y chromium); set VT_REQUIRE_CHROMIUM=1 to fail instead");
    }
    found
}

/// Runs headless Chromium on `url` with `extra` flags and a fresh profile; returns (stdout,
/// console lines from stderr). Fails the test if Chromium cannot run.
fn run_chromium(exe: &Path, dir: &Path, url: &str, window: (u32, u32), extra: &[&str]) -> (String, Vec<String>) {
    let profile = dir.join(format!("profile-{}", extra.join("").len()));
    let _ = std::fs::remove_dir_all(&profile);
    let size = format!("--window-size={},{}", window.0, window.1);
    let out = Command::new(exe)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-dev-shm-usage",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--hide-scrollbars",
            "--force-device-scale-factor=1",
            "--enable-logging=stderr",
            "--v=0",
            &size,
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .args(extra)
        .arg(url)
        .output()
        .unwrap_or_else(|e| panic!("{} cannot be started: {e}", exe.display()));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "headless chromium failed ({}):\n{stderr}", out.status);
    // Chromium's stderr log does not show a console message's level; the page writes nothing
    // to the console, so every console line is unexpected.
    let console = stderr.lines().filter(|l| l.contains(":CONSOLE")).map(str::to_owned).collect();
    (String::from_utf8_lossy(&out.stdout).into_owned(), console)
}

/// The JSON the page wrote into `<pre id="vt-state">`.
fn page_state(dom: &str) -> serde_json::Value {
    let start = dom.find("id=\"vt-state\"").expect("#vt-state in the DOM");
    let rest = &dom[start..];
    let open = rest.find('>').expect("#vt-state opens") + 1;
    let close = rest.find("</pre>").expect("#vt-state closes");
    let text = rest[open..close].replace("&quot;", "\"").replace("&amp;", "&").replace("&lt;", "<").replace("&gt;", ">");
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("#vt-state is not JSON ({e}): {text}"))
}

fn hex_rgb(s: &str) -> [u8; 3] {
    let v = u32::from_str_radix(s.trim_start_matches('#'), 16).expect("#rrggbb colour");
    [(v >> 16) as u8, (v >> 8) as u8, v as u8]
}

fn dist(a: [u8; 3], b: [u8; 3]) -> u32 {
    a.iter().zip(b).map(|(&x, y)| u32::from(x.abs_diff(y))).sum()
}

#[test]
fn replay_plays_in_headless_chromium_and_shows_the_uavs() {
    let Some(exe) = chromium() else { return };
    let dir = std::env::temp_dir().join(format!("vt-replay-browser-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");

    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/experiment-3uav.toml");
    let ls = scenario::load(Some(&path)).expect("valid scenario");
    let o = sim::run(&ls, &RunOptions { record: true, ..RunOptions::default() }).expect("run starts");
    let file = replay::write(&dir, &o.scene, &[&o.record]).expect("replay written");
    let url = format!("file://{}", file.display());

    // 1. Loads, plays: from t = 0, 2 s of virtual time later the clock has ticked and the
    //    frame index moved on; no console message, no script error.
    let (dom, console) = run_chromium(&exe, &dir, &url, WINDOW, &["--virtual-time-budget=2000", "--dump-dom"]);
    assert!(console.is_empty(), "console messages: {console:#?}");
    let s = page_state(&dom);
    println!("playing: {s}");
    assert_eq!(s["errors"].as_array().map(Vec::len), Some(0), "page errors: {}", s["errors"]);
    assert!(s["ticks"].as_u64().unwrap_or(0) > 0, "the clock never ticked: {s}");
    let frame = s["frame"][0].as_i64().unwrap_or(-1);
    let frames = s["frames"][0].as_i64().unwrap_or(0);
    assert!(frame > 0 && frame < frames, "frame {frame} of {frames}: the animation did not advance");
    assert!(s["time"].as_f64().unwrap_or(0.0) > 0.5, "time did not advance: {s}");

    // 2. Paused at SHOT_T_S: where the page says the UAVs are ...
    let paused = format!("{url}#t={SHOT_T_S}&paused");
    let (dom, console) = run_chromium(&exe, &dir, &paused, WINDOW, &["--virtual-time-budget=1000", "--dump-dom"]);
    assert!(console.is_empty(), "console messages: {console:#?}");
    let s = page_state(&dom);
    assert_eq!(s["playing"], false);
    assert!((s["time"].as_f64().unwrap_or(-1.0) - SHOT_T_S).abs() < 1e-6, "time {} not {SHOT_T_S}", s["time"]);
    let bg = hex_rgb(s["background"].as_str().expect("background colour"));
    let colors: Vec<[u8; 3]> =
        s["colors"][0].as_array().expect("UAV colours").iter().map(|c| hex_rgb(c.as_str().expect("colour"))).collect();
    assert_eq!(colors.len(), 3);

    // ... and the screenshot of the same page.
    let shot = dir.join("replay.png");
    let _ = std::fs::remove_file(&shot);
    let shot_flag = format!("--screenshot={}", shot.display());
    let vp = |i: usize| s["viewport"][i].as_u64().and_then(|v| u32::try_from(v).ok()).expect("viewport in #vt-state");
    let viewport = (vp(0), vp(1));
    let (_, console) = run_chromium(&exe, &dir, &paused, viewport, &["--virtual-time-budget=1000", &shot_flag]);
    assert!(console.is_empty(), "console messages: {console:#?}");
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&shot).expect("screenshot written")));
    let mut reader = decoder.read_info().expect("PNG header");
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).expect("PNG data");
    assert_eq!((info.width, info.height), viewport, "screenshot size is not the viewport the positions were taken in");
    let channels = info.color_type.samples();
    assert!(channels >= 3, "screenshot colour type {:?}", info.color_type);
    let px = |x: f64, y: f64| -> [u8; 3] {
        let (x, y) = (x.round() as usize, y.round() as usize);
        assert!(x < info.width as usize && y < info.height as usize, "({x}, {y}) outside the screenshot");
        let i = (y * info.width as usize + x) * channels;
        [buf[i], buf[i + 1], buf[i + 2]]
    };

    // Not blank: many colours, and most of the picture is not the page background.
    let mut distinct = std::collections::HashSet::new();
    for y in (0..info.height).step_by(7) {
        for x in (0..info.width).step_by(7) {
            distinct.insert(px(f64::from(x), f64::from(y)));
        }
    }
    println!("screenshot {} x {}, {} distinct colours (sampled)", info.width, info.height, distinct.len());
    assert!(distinct.len() > 50, "screenshot looks blank: {} colours", distinct.len());

    // The UAVs, in the 3-D view and in the top view, drawn in their colours.
    for view in ["uav_px", "top_px"] {
        let pts = s[view][0].as_array().unwrap_or_else(|| panic!("{view} in #vt-state"));
        assert_eq!(pts.len(), colors.len(), "{view}: one position per UAV");
        for (i, (p, &c)) in pts.iter().zip(&colors).enumerate() {
            let (x, y) = (p[0].as_f64().expect("x"), p[1].as_f64().expect("y"));
            let got = px(x, y);
            println!("{view} UAV {i} at ({x:.0}, {y:.0}): pixel {got:?}, colour {c:?}, background {bg:?}");
            assert!(dist(got, bg) > 60, "{view}: UAV {i} at ({x}, {y}) is background {got:?}");
            assert!(dist(got, c) < 60, "{view}: UAV {i} at ({x}, {y}) is {got:?}, not its colour {c:?}");
        }
    }
    let keep = Path::new(env!("CARGO_TARGET_TMPDIR")).join("replay_browser.png");
    let _ = std::fs::copy(&shot, &keep);
    let _ = std::fs::remove_dir_all(&dir);
}

/// `compare`: both controllers in one page, side by side and overlaid; no console message,
/// both runs' UAVs at their published positions in their colours.
#[test]
fn comparison_replay_shows_both_runs_side_by_side_and_overlaid() {
    let Some(exe) = chromium() else { return };
    let dir = std::env::temp_dir().join(format!("vt-replay-compare-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/experiment-3uav.toml");
    let ls = scenario::load(Some(&path)).expect("valid scenario");
    let a = sim::run(&ls, &RunOptions { record: true, ..RunOptions::default() }).expect("dissipative run");
    let b = sim::run(&ls, &RunOptions { record: true, controller: sim::ControllerKind::Baseline, ..RunOptions::default() })
        .expect("baseline run");
    let file = replay::write(&dir, &a.scene, &[&a.record, &b.record]).expect("replay written");
    for layout in ["", "&overlay"] {
        let url = format!("file://{}#t=10&paused{layout}", file.display());
        let (dom, console) = run_chromium(&exe, &dir, &url, WINDOW, &["--virtual-time-budget=1000", "--dump-dom"]);
        assert!(console.is_empty(), "{layout}: console messages: {console:#?}");
        let s = page_state(&dom);
        println!("compare{layout}: {s}");
        assert_eq!(s["errors"].as_array().map(Vec::len), Some(0), "page errors: {}", s["errors"]);
        assert_eq!(s["frames"].as_array().map(Vec::len), Some(2), "two runs");
        for run in 0..2 {
            assert!(s["frame"][run].as_i64().unwrap_or(-1) > 0, "{layout}: run {run} frame {}", s["frame"][run]);
            assert_eq!(s["uav_px"][run].as_array().map(Vec::len), Some(3), "{layout}: run {run} UAV positions");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Size (issue 17): the replay of the 10-UAV paper mission stays under about 5 MB, the
/// comparison page (two runs) included. No browser needed.
#[test]
fn paper_mission_replay_stays_under_5_mb() {
    const LIMIT_BYTES: usize = 5_000_000;
    let ls = scenario::load(None).expect("built-in paper scenario");
    let a = sim::run(&ls, &RunOptions { record: true, ..RunOptions::default() }).expect("dissipative run");
    let b = sim::run(&ls, &RunOptions { record: true, controller: sim::ControllerKind::Baseline, ..RunOptions::default() })
        .expect("baseline run");
    let one = replay::html(&a.scene, &[&a.record]).expect("page").len();
    let both = replay::html(&a.scene, &[&a.record, &b.record]).expect("page").len();
    println!("paper mission replay: run {one} bytes, compare {both} bytes ({} samples)", a.record.time_s.len());
    assert!(a.record.time_s.len() > 500, "the mission was recorded");
    assert!(one < LIMIT_BYTES && both < LIMIT_BYTES, "run {one} B, compare {both} B: over {LIMIT_BYTES} B");
}
