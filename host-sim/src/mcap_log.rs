//! The MCAP log of a run (issue 17, `--mcap FILE`), for Foxglove: JSON messages on Foxglove's
//! well-known schemas where they fit, plain JSON topics for the rest (docs/replay.md).
//!
//! | topic | schema | one message |
//! |---|---|---|
//! | `/tf` | `foxglove.FrameTransform` | per sample and body: `world` -> `uav<i>` / `load` |
//! | `/scene/tube` | `foxglove.SceneUpdate` | once: tube boundaries, centre line, obstacles |
//! | `/scene/team` | `foxglove.SceneUpdate` | per sample: UAVs, load, cables coloured by tension |
//! | `/tensions` | `vt.Tensions` | per sample: tensions, rated capacity, N |
//! | `/commands` | `vt.Commands` | per sample: thrust, N; velocity command, m/s (when recorded) |
//! | `/cfo` | `vt.CfoEstimate` | per sample, when recorded: CFO cable-force estimate, N |
//! | `/clearances` | `vt.Clearances` | per sample: distances and load altitude error, m |
//! | `/mode` | `vt.Mode` | per sample, when recorded: 0 transport, 1 hold |
//! | `/events` | `vt.Event` | per fault or hold change |
//!
//! With two runs (`compare`) every topic and frame is prefixed with the controller's name
//! (`/dissipative/tf`, frame `dissipative/uav0`). Log time = simulated time (ns from 0, so
//! Foxglove shows it as 1970-01-01). Uncompressed: the `mcap` crate is built without its
//! compression features (zstd/lz4 would pull C code into the build).

use crate::record::{RunRecord, SceneGeometry};
use mcap::records::MessageHeader;
use serde_json::{json, Value};
use std::collections::BTreeMap;
use std::io::BufWriter;
use std::path::Path;

/// Foxglove schemas are named `foxglove.<Type>` with JSON Schema encoding; these minimal
/// schemas name the fields we write (Foxglove picks its renderer from the schema name).
const FOXGLOVE_SCHEMAS: [(&str, &str); 2] = [
    ("foxglove.FrameTransform", r#"{"type":"object","properties":{"timestamp":{"type":"object"},"parent_frame_id":{"type":"string"},"child_frame_id":{"type":"string"},"translation":{"type":"object"},"rotation":{"type":"object"}}}"#),
    ("foxglove.SceneUpdate", r#"{"type":"object","properties":{"deletions":{"type":"array"},"entities":{"type":"array"}}}"#),
];
/// Height of the obstacle cylinders drawn in the scene, m (the scene is 2-D: infinite columns).
const OBSTACLE_HEIGHT_M: f64 = 12.0;
/// Thickness of the cable lines, m.
const CABLE_THICKNESS_M: f64 = 0.03;
/// Diameter of the UAV spheres, m.
const UAV_SIZE_M: f64 = 0.4;
/// Edge of the load cube, m.
const LOAD_SIZE_M: f64 = 0.3;

/// What [`write`] wrote.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LogStats {
    /// Messages per topic.
    pub messages: BTreeMap<String, u64>,
    /// First and last log time, ns.
    pub time_range_ns: (u64, u64),
}

/// Writes the MCAP log of `runs` (one, or two for a comparison) flown in `scene` to `path`.
///
/// # Errors
/// I/O or MCAP errors, as text naming the file.
pub fn write(path: &Path, scene: &SceneGeometry, runs: &[&RunRecord]) -> Result<LogStats, String> {
    let err = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| err(&e))?;
    }
    let file = std::fs::File::create(path).map_err(|e| err(&e))?;
    let opts = mcap::WriteOptions::new().compression(None).profile("").library(concat!("host-sim ", env!("CARGO_PKG_VERSION")));
    let mut w = Log { w: opts.create(BufWriter::new(file)).map_err(|e| err(&e))?, schemas: BTreeMap::new(), stats: LogStats { messages: BTreeMap::new(), time_range_ns: (u64::MAX, 0) } };
    for (name, text) in FOXGLOVE_SCHEMAS {
        let id = w.w.add_schema(name, "jsonschema", text.as_bytes()).map_err(|e| err(&e))?;
        w.schemas.insert(name, id);
    }
    for run in runs {
        let prefix = if runs.len() > 1 { format!("/{}", run.controller) } else { String::new() };
        write_run(&mut w, scene, run, &prefix).map_err(|e| err(&e))?;
    }
    w.w.finish().map_err(|e| err(&e))?;
    if w.stats.time_range_ns.0 > w.stats.time_range_ns.1 {
        w.stats.time_range_ns = (0, 0);
    }
    Ok(w.stats)
}

/// The writer, its schema ids and what it wrote so far.
struct Log {
    w: mcap::Writer<BufWriter<std::fs::File>>,
    schemas: BTreeMap<&'static str, u16>,
    stats: LogStats,
}

impl Log {
    /// A JSON channel on `topic` with the Foxglove schema `schema`, or a plain JSON schema
    /// named `schema` (`vt.*`) describing an object.
    fn channel(&mut self, topic: &str, schema: &'static str) -> mcap::McapResult<u16> {
        let id = match self.schemas.get(schema) {
            Some(&id) => id,
            None => {
                let id = self.w.add_schema(schema, "jsonschema", br#"{"type":"object"}"#)?;
                self.schemas.insert(schema, id);
                id
            }
        };
        self.w.add_channel(id, topic, "json", &BTreeMap::new())
    }

    /// Writes `msg` on `channel` (topic `topic`) at simulated time `t_s`.
    fn put(&mut self, channel: u16, topic: &str, t_s: f64, msg: &Value) -> mcap::McapResult<()> {
        let ns = ns(t_s);
        let count = self.stats.messages.entry(topic.to_owned()).or_insert(0);
        let sequence = u32::try_from(*count).unwrap_or(u32::MAX);
        *count += 1;
        self.stats.time_range_ns = (self.stats.time_range_ns.0.min(ns), self.stats.time_range_ns.1.max(ns));
        let data = serde_json::to_vec(msg).unwrap_or_default();
        self.w.write_to_known_channel(&MessageHeader { channel_id: channel, sequence, log_time: ns, publish_time: ns }, &data)
    }
}

/// Simulated time `t_s` (s, clamped at 0) as integer nanoseconds.
fn ns(t_s: f64) -> u64 {
    if t_s.is_finite() && t_s > 0.0 {
        (t_s * 1e9).round() as u64
    } else {
        0
    }
}

/// Foxglove `Time` of `t_s`.
fn stamp(t_s: f64) -> Value {
    let ns = ns(t_s);
    json!({ "sec": ns / 1_000_000_000, "nsec": ns % 1_000_000_000 })
}

/// `{x, y, z}` of a point, m, rounded to 0.1 mm (keeps the JSON short; the plant's position
/// noise is larger).
fn v3(p: [f64; 3]) -> Value {
    let r = |v: f64| (v * 1e4).round() / 1e4;
    json!({ "x": r(p[0]), "y": r(p[1]), "z": r(p[2]) })
}

/// Foxglove `Pose` at `p` with identity orientation.
fn pose(p: [f64; 3]) -> Value {
    json!({ "position": v3(p), "orientation": { "x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0 } })
}

/// RGBA colour in 0..1.
fn rgba(c: [f64; 4]) -> Value {
    json!({ "r": c[0], "g": c[1], "b": c[2], "a": c[3] })
}

/// Tension colour against the rated capacity: green at 0, yellow at half, red at the capacity
/// (the replay's ramp, `replay.js` `tensionColor`, in three stops).
fn tension_rgba(f: f64, rated: f64) -> [f64; 4] {
    if !f.is_finite() {
        return [0.55, 0.55, 0.55, 1.0];
    }
    let x = (f / rated.max(1e-9)).clamp(0.0, 1.0);
    let (a, b, s) = if x < 0.5 { ([0.10, 0.60, 0.31], [1.0, 0.88, 0.55], x / 0.5) } else { ([1.0, 0.88, 0.55], [0.84, 0.19, 0.15], (x - 0.5) / 0.5) };
    [a[0] + s * (b[0] - a[0]), a[1] + s * (b[1] - a[1]), a[2] + s * (b[2] - a[2]), 1.0]
}

/// A Foxglove `SceneEntity` with the given primitives.
fn entity(t_s: f64, frame: &str, id: &str, prims: &[(&str, Vec<Value>)]) -> Value {
    let mut e = json!({
        "timestamp": stamp(t_s), "frame_id": frame, "id": id, "lifetime": { "sec": 0, "nsec": 0 },
        "frame_locked": false, "metadata": [], "arrows": [], "cubes": [], "spheres": [], "cylinders": [],
        "lines": [], "triangles": [], "texts": [], "models": [],
    });
    for (kind, list) in prims {
        e[*kind] = Value::Array(list.clone());
    }
    e
}

/// A Foxglove `LinePrimitive` (type 0 line strip, 2 line list) through `pts`.
fn line(kind: u8, pts: impl IntoIterator<Item = [f64; 3]>, thickness: f64, color: [f64; 4], colors: Vec<Value>) -> Value {
    json!({
        "type": kind, "pose": pose([0.0; 3]), "thickness": thickness, "scale_invariant": false,
        "points": pts.into_iter().map(v3).collect::<Vec<_>>(), "color": rgba(color), "colors": colors, "indices": [],
    })
}

fn write_run(w: &mut Log, scene: &SceneGeometry, r: &RunRecord, prefix: &str) -> mcap::McapResult<()> {
    let world = "world";
    let frame = |name: &str| if prefix.is_empty() { name.to_owned() } else { format!("{}/{name}", prefix.trim_start_matches('/')) };
    let topic = |name: &str| format!("{prefix}{name}");
    let t0 = r.time_s.first().copied().unwrap_or(0.0);
    let rated = r.rated_capacity_n();

    // Static scene, once.
    let (t_tube, t_team) = (topic("/scene/tube"), topic("/scene/team"));
    let ch = w.channel(&t_tube, "foxglove.SceneUpdate")?;
    let flat = |pts: &[[f64; 2]]| pts.iter().map(|p| [p[0], p[1], 0.0]).collect::<Vec<_>>();
    let tube = vec![
        line(0, flat(&scene.left_boundary), 0.06, [0.16, 0.22, 0.35, 1.0], vec![]),
        line(0, flat(&scene.right_boundary), 0.06, [0.16, 0.22, 0.35, 1.0], vec![]),
        line(0, flat(&scene.centerline), 0.03, [0.5, 0.5, 0.5, 1.0], vec![]),
    ];
    let cylinders: Vec<Value> = scene
        .obstacles
        .iter()
        .map(|o| {
            let d = 2.0 * o.radius_m;
            json!({ "pose": pose([o.center_m[0], o.center_m[1], OBSTACLE_HEIGHT_M / 2.0]), "size": v3([d, d, OBSTACLE_HEIGHT_M]),
                    "bottom_scale": 1.0, "top_scale": 1.0, "color": rgba([0.6, 0.6, 0.6, 0.8]) })
        })
        .collect();
    let static_scene = json!({ "deletions": [], "entities": [
        entity(t0, world, "tube", &[("lines", tube)]),
        entity(t0, world, "obstacles", &[("cylinders", cylinders)]),
    ]});
    w.put(ch, &t_tube, t0, &static_scene)?;

    let names = ["/tf", "/tensions", "/commands", "/cfo", "/clearances", "/mode", "/events"].map(topic);
    let [t_tf, t_ten, t_cmd, t_cfo, t_clr, t_mode, t_ev] = &names;
    let ch_tf = w.channel(t_tf, "foxglove.FrameTransform")?;
    let ch_team = w.channel(&t_team, "foxglove.SceneUpdate")?;
    let ch_ten = w.channel(t_ten, "vt.Tensions")?;
    let ch_cmd = w.channel(t_cmd, "vt.Commands")?;
    let ch_clr = w.channel(t_clr, "vt.Clearances")?;
    let ch_cfo = if r.f_hat_n.is_empty() { None } else { Some(w.channel(t_cfo, "vt.CfoEstimate")?) };
    let ch_mode = if r.uav_mode.is_empty() { None } else { Some(w.channel(t_mode, "vt.Mode")?) };

    for (k, &t) in r.time_s.iter().enumerate() {
        let (Some(uavs), Some(&load)) = (r.uav_pos_m.get(k), r.load_pos_m.get(k)) else { continue };
        let ten = r.tension_n.get(k).map_or(&[][..], Vec::as_slice);
        for (i, &p) in uavs.iter().enumerate() {
            let msg = json!({ "timestamp": stamp(t), "parent_frame_id": world, "child_frame_id": frame(&format!("uav{i}")),
                              "translation": v3(p), "rotation": { "x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0 } });
            w.put(ch_tf, t_tf, t, &msg)?;
        }
        let msg = json!({ "timestamp": stamp(t), "parent_frame_id": world, "child_frame_id": frame("load"),
                          "translation": v3(load), "rotation": { "x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0 } });
        w.put(ch_tf, t_tf, t, &msg)?;

        // The team: cables (a line list, one colour per cable end), UAVs, load.
        let mut pts = Vec::with_capacity(2 * uavs.len());
        let mut cols = Vec::with_capacity(2 * uavs.len());
        for (i, &p) in uavs.iter().enumerate() {
            let c = rgba(tension_rgba(ten.get(i).copied().unwrap_or(f64::NAN), rated));
            pts.extend([p, load]);
            cols.extend([c.clone(), c]);
        }
        let spheres: Vec<Value> = uavs
            .iter()
            .map(|&p| json!({ "pose": pose(p), "size": v3([UAV_SIZE_M; 3]), "color": rgba([0.12, 0.47, 0.71, 1.0]) }))
            .collect();
        let cube = json!({ "pose": pose(load), "size": v3([LOAD_SIZE_M; 3]), "color": rgba([0.1, 0.1, 0.1, 1.0]) });
        let team = json!({ "deletions": [], "entities": [entity(t, world, "team", &[
            ("lines", vec![line(2, pts, CABLE_THICKNESS_M, [0.5, 0.5, 0.5, 1.0], cols)]),
            ("spheres", spheres),
            ("cubes", vec![cube]),
        ])]});
        w.put(ch_team, &t_team, t, &team)?;

        w.put(ch_ten, t_ten, t, &json!({ "tension_n": ten, "rated_n": rated, "f_max_n": r.f_max_n }))?;
        let mut cmd = json!({ "thrust_n": r.thrust_n.get(k) });
        if let Some(v) = r.vel_cmd_mps.get(k) {
            cmd["vel_cmd_mps"] = json!(v);
        }
        w.put(ch_cmd, t_cmd, t, &cmd)?;
        if let (Some(ch), Some(f)) = (ch_cfo, r.f_hat_n.get(k)) {
            w.put(ch, t_cfo, t, &json!({ "f_hat_n": f }))?;
        }
        let clr = json!({
            "min_uav_boundary_m": r.min_uav_boundary_m.get(k), "load_boundary_m": r.min_load_boundary_m.get(k),
            "min_uav_uav_m": r.min_uav_uav_m.get(k), "load_altitude_error_m": load[2] - r.load_altitude_ref_m,
        });
        w.put(ch_clr, t_clr, t, &clr)?;
        if let (Some(ch), Some(m)) = (ch_mode, r.uav_mode.get(k)) {
            w.put(ch, t_mode, t, &json!({ "mode": m }))?;
        }
    }
    if !r.events.is_empty() {
        let ch = w.channel(t_ev, "vt.Event")?;
        for e in &r.events {
            w.put(ch, t_ev, e.time_s, &json!(e))?;
        }
    }
    Ok(())
}
