//! The replay's inline data: the scene and each run's samples as integers (mm, ms, 0.1 N),
//! so the page stays small; `null` where a sample is non-finite.

use crate::record::{RecordEvent, RunRecord, SceneGeometry, MODE_TRANSPORT};
use serde::Serialize;
use vt_dissipative::TrayParams;

/// Positions are written in these units per metre (mm).
const MM_PER_M: f64 = 1000.0;
/// Times are written in these units per second (ms).
const MS_PER_S: f64 = 1000.0;
/// Tensions are written in these units per newton (0.1 N).
const DN_PER_N: f64 = 10.0;
/// Tube polylines are thinned to points at least this far apart, m (the tube's arc-length
/// table is much finer than a screen needs).
const TUBE_STEP_M: f64 = 0.1;

/// The whole blob.
#[derive(Debug, Serialize)]
pub struct ReplayData<'a> {
    /// Page title.
    pub title: String,
    /// Static geometry.
    pub scene: Scene,
    /// One or two runs (two: a comparison).
    pub runs: Vec<Run<'a>>,
}

/// Static geometry, mm.
#[derive(Debug, Serialize)]
pub struct Scene {
    /// Centre line `[x, y]`, mm.
    pub centerline: Vec<[i64; 2]>,
    /// Left boundary, mm.
    pub left: Vec<[i64; 2]>,
    /// Right boundary, mm.
    pub right: Vec<[i64; 2]>,
    /// Obstacles `[x, y, radius]`, mm.
    pub obstacles: Vec<[i64; 3]>,
    /// `[x_min, x_max, y_min, y_max]`, mm.
    pub bounds: [i64; 4],
}

/// One run's samples.
#[derive(Debug, Serialize)]
pub struct Run<'a> {
    /// Controller name.
    pub controller: &'a str,
    /// Scenario name.
    pub scenario: &'a str,
    /// Number of UAVs.
    pub n: usize,
    /// UAV colours `#rrggbb` (the plots' palette).
    pub colors: Vec<String>,
    /// Capacity tensions are coloured against, N.
    pub rated_n: f64,
    /// Cable cap `f_max`, N.
    pub f_max_n: f64,
    /// Load altitude reference, m.
    pub alt_ref_m: f64,
    /// Tray height above the load, m (0: no tray).
    pub tray_h_m: f64,
    /// Sample times, ms.
    pub t: Vec<Option<i64>>,
    /// UAV positions per sample, flat `[x0, y0, z0, x1, ...]`, mm.
    pub uav: Vec<Vec<Option<i64>>>,
    /// Load position per sample `[x, y, z]`, mm.
    pub load: Vec<[Option<i64>; 3]>,
    /// Cable tensions per sample, 0.1 N.
    pub ten: Vec<Vec<Option<i64>>>,
    /// Tray nodes per sample, flat `[x0, y0, x1, ...]`, mm (empty without a tray).
    pub node: Vec<Vec<Option<i64>>>,
    /// Controller mode per sample, one digit per UAV (0 transport, 1 hold); may be empty.
    pub mode: Vec<String>,
    /// Clearances per sample `[min UAV-boundary, load-boundary, min UAV-UAV]`, mm.
    pub clear: Vec<[Option<i64>; 3]>,
    /// Faults and hold changes.
    pub events: &'a [RecordEvent],
}

fn q(x: f64, per_unit: f64) -> Option<i64> {
    let v = (x * per_unit).round();
    // i64 holds every rounded finite value a flight produces; the bound keeps the cast exact.
    (v.is_finite() && v.abs() < 9.0e15).then_some(v as i64)
}

fn mm2(p: [f64; 2]) -> [i64; 2] {
    [q(p[0], MM_PER_M).unwrap_or(0), q(p[1], MM_PER_M).unwrap_or(0)]
}

fn mm3(p: [f64; 3]) -> [Option<i64>; 3] {
    [q(p[0], MM_PER_M), q(p[1], MM_PER_M), q(p[2], MM_PER_M)]
}

/// Keeps points at least `step` apart (always the first and the last), mm.
fn thin(line: &[[f64; 2]], step: f64) -> Vec<[i64; 2]> {
    let mut out: Vec<[f64; 2]> = Vec::new();
    for (k, p) in line.iter().enumerate() {
        if !(p[0].is_finite() && p[1].is_finite()) {
            continue;
        }
        let far = out.last().is_none_or(|l| (p[0] - l[0]).hypot(p[1] - l[1]) >= step);
        if far || k + 1 == line.len() {
            out.push(*p);
        }
    }
    out.into_iter().map(mm2).collect()
}

/// The page title: scenario and controller(s).
pub fn title(runs: &[&RunRecord]) -> String {
    let scenario = runs.first().map_or("", |r| r.scenario.as_str());
    let ctrl: Vec<&str> = runs.iter().map(|r| r.controller.as_str()).collect();
    format!("{scenario} - {} - replay", ctrl.join(" vs "))
}

/// Tray nodes of one sample (eq:2-4 via [`TrayParams::project`]), flat `[x, y, ...]`, mm.
fn nodes(tray: &TrayParams, uavs: &[[f64; 3]], load: [f64; 3]) -> Vec<Option<i64>> {
    let f = |p: [f64; 3]| vt_dissipative::Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32);
    let l = f(load);
    let finite = |p: &[f64; 3]| p.iter().all(|x| x.is_finite());
    let mut out = Vec::with_capacity(2 * uavs.len());
    for u in uavs {
        if finite(u) && finite(&load) {
            let (node, _) = tray.project(&f(*u), &l);
            out.push(q(f64::from(node.x), MM_PER_M));
            out.push(q(f64::from(node.y), MM_PER_M));
        } else {
            out.extend([None, None]);
        }
    }
    out
}

fn run(r: &RunRecord) -> Run<'_> {
    let n = r.uav_pos_m.first().map_or(0, Vec::len);
    let tray = (r.tray_height_m > 0.0).then(|| TrayParams { height_above_load_m: r.tray_height_m as f32, ..TrayParams::default() });
    let k = r.time_s.len();
    let load = |i: usize| r.load_pos_m.get(i).copied().unwrap_or([f64::NAN; 3]);
    let clear = |v: &[f64], i: usize| v.get(i).and_then(|x| q(*x, MM_PER_M));
    Run {
        controller: &r.controller,
        scenario: &r.scenario,
        n,
        colors: (0..n)
            .map(|i| {
                let c = crate::plots::uav_color(i);
                format!("#{:02x}{:02x}{:02x}", c.0, c.1, c.2)
            })
            .collect(),
        rated_n: r.rated_capacity_n(),
        f_max_n: r.f_max_n,
        alt_ref_m: r.load_altitude_ref_m,
        tray_h_m: r.tray_height_m,
        t: r.time_s.iter().map(|t| q(*t, MS_PER_S)).collect(),
        uav: (0..k)
            .map(|i| r.uav_pos_m.get(i).map_or_else(Vec::new, |u| u.iter().flat_map(|p| mm3(*p)).collect()))
            .collect(),
        load: (0..k).map(|i| mm3(load(i))).collect(),
        ten: (0..k).map(|i| r.tension_n.get(i).map_or_else(Vec::new, |t| t.iter().map(|x| q(*x, DN_PER_N)).collect())).collect(),
        node: match tray {
            Some(tray) => (0..k).map(|i| r.uav_pos_m.get(i).map_or_else(Vec::new, |u| nodes(&tray, u, load(i)))).collect(),
            None => Vec::new(),
        },
        mode: r
            .uav_mode
            .iter()
            .take(k)
            .map(|m| m.iter().map(|&x| if x == MODE_TRANSPORT { '0' } else { '1' }).collect())
            .collect(),
        clear: (0..k).map(|i| [clear(&r.min_uav_boundary_m, i), clear(&r.min_load_boundary_m, i), clear(&r.min_uav_uav_m, i)]).collect(),
        events: &r.events,
    }
}

/// The blob for `runs` in `scene`.
pub fn build<'a>(scene: &SceneGeometry, runs: &[&'a RunRecord]) -> ReplayData<'a> {
    let b = scene.bounds_m;
    ReplayData {
        title: title(runs),
        scene: Scene {
            centerline: thin(&scene.centerline, TUBE_STEP_M),
            left: thin(&scene.left_boundary, TUBE_STEP_M),
            right: thin(&scene.right_boundary, TUBE_STEP_M),
            obstacles: scene
                .obstacles
                .iter()
                .map(|o| {
                    let [x, y] = mm2(o.center_m);
                    [x, y, q(o.radius_m, MM_PER_M).unwrap_or(0)]
                })
                .collect(),
            bounds: [b[0], b[1], b[2], b[3]].map(|v| q(v, MM_PER_M).unwrap_or(0)),
        },
        runs: runs.iter().map(|r| run(r)).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_are_rounded_to_mm_and_tenths_of_newtons_and_nan_is_null() {
        assert_eq!(q(1.23456, MM_PER_M), Some(1235));
        assert_eq!(q(12.34, DN_PER_N), Some(123));
        assert_eq!(q(f64::NAN, MM_PER_M), None);
        assert_eq!(q(f64::INFINITY, MM_PER_M), None);
    }

    #[test]
    fn thinning_keeps_ends_and_spacing() {
        let line: Vec<[f64; 2]> = (0..=100).map(|i| [f64::from(i) * 0.01, 0.0]).collect();
        let t = thin(&line, TUBE_STEP_M);
        assert_eq!(t.first(), Some(&[0, 0]));
        assert_eq!(t.last(), Some(&[1000, 0]));
        assert_eq!(t.len(), 11);
    }

    #[test]
    fn tray_nodes_follow_the_projection() {
        // UAV 2 m out and 4 m above the load, tray 2 m above it: node 1 m out (eq:2-4).
        let tray = TrayParams { height_above_load_m: 2.0, ..TrayParams::default() };
        let n = nodes(&tray, &[[2.0, 0.0, 4.0]], [0.0, 0.0, 0.0]);
        assert_eq!(n, vec![Some(1000), Some(0)]);
    }
}
