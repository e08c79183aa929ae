//! The MCAP log (issue 17, `--mcap`): a real flight (the 3-UAV experiment) written with
//! `host_sim::mcap_log` and read back with the `mcap` crate: topics, schemas, message counts,
//! time range, and the logged positions against the run's record.

use host_sim::mcap_log;
use host_sim::sim::{self, RunOptions};
use host_sim::scenario;
use std::collections::BTreeMap;
use std::path::Path;

#[test]
fn mcap_log_reads_back_with_the_runs_topics_counts_and_times() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/experiment-3uav.toml");
    let ls = scenario::load(Some(&path)).expect("valid scenario");
    let o = sim::run(&ls, &RunOptions { record: true, ..RunOptions::default() }).expect("run starts");
    let r = &o.record;
    let (k, n) = (r.time_s.len(), r.uav_pos_m.first().map_or(0, Vec::len));
    assert!(k > 100 && n == 3, "{k} samples, {n} UAVs");

    let file = Path::new(env!("CARGO_TARGET_TMPDIR")).join("mcap_log/experiment.mcap");
    let stats = mcap_log::write(&file, &o.scene, &[r]).expect("log written");
    let bytes = std::fs::read(&file).expect("log read");

    // Every message, by topic, with its schema and encoding.
    let mut count: BTreeMap<String, u64> = BTreeMap::new();
    let mut schema: BTreeMap<String, (String, String)> = BTreeMap::new();
    let (mut t_min, mut t_max) = (u64::MAX, 0);
    let mut tf = Vec::new();
    for m in mcap::MessageStream::new(&bytes).expect("MCAP header") {
        let m = m.expect("message");
        let topic = m.channel.topic.clone();
        *count.entry(topic.clone()).or_default() += 1;
        let s = m.channel.schema.as_ref().expect("every channel has a schema");
        schema.insert(topic.clone(), (s.name.clone(), m.channel.message_encoding.clone()));
        (t_min, t_max) = (t_min.min(m.log_time), t_max.max(m.log_time));
        let v: serde_json::Value = serde_json::from_slice(&m.data).expect("JSON message");
        if topic == "/tf" {
            tf.push((m.log_time, v));
        }
    }
    println!("{} bytes, {count:?}", bytes.len());

    let k = k as u64;
    let n = n as u64;
    let mut expect = BTreeMap::from([
        ("/tf".to_owned(), k * (n + 1)),
        ("/scene/tube".to_owned(), 1),
        ("/scene/team".to_owned(), k),
        ("/tensions".to_owned(), k),
        ("/commands".to_owned(), k),
        ("/clearances".to_owned(), k),
    ]);
    if !r.f_hat_n.is_empty() {
        expect.insert("/cfo".to_owned(), k);
    }
    if !r.uav_mode.is_empty() {
        expect.insert("/mode".to_owned(), k);
    }
    if !r.events.is_empty() {
        expect.insert("/events".to_owned(), r.events.len() as u64);
    }
    assert_eq!(count, expect, "topics and message counts");
    assert_eq!(stats.messages, expect, "what the writer says it wrote");
    for (topic, (name, enc)) in &schema {
        assert_eq!(enc, "json", "{topic}");
        let want = match topic.as_str() {
            "/tf" => "foxglove.FrameTransform",
            "/scene/tube" | "/scene/team" => "foxglove.SceneUpdate",
            _ => name.as_str(),
        };
        assert_eq!(name, want, "{topic}");
    }

    // Time range: the record's first to last sample, ns.
    let ns = |t: f64| (t * 1e9).round() as u64;
    assert_eq!((t_min, t_max), (ns(r.time_s[0]), ns(r.time_s[r.time_s.len() - 1])));
    assert_eq!(stats.time_range_ns, (t_min, t_max));

    // The summary section agrees (Foxglove reads it to seek).
    let summary = mcap::Summary::read(&bytes).expect("summary").expect("summary present");
    let st = summary.stats.expect("statistics");
    assert_eq!(st.message_count, count.values().sum::<u64>());
    assert_eq!((st.message_start_time, st.message_end_time), (t_min, t_max));

    // Positions: the transform of UAV 1 and of the load at the middle sample, to 0.1 mm.
    let mid = r.time_s.len() / 2;
    let at = ns(r.time_s[mid]);
    for (child, p) in [("uav1", r.uav_pos_m[mid][1]), ("load", r.load_pos_m[mid])] {
        let (_, v) = tf.iter().find(|(t, v)| *t == at && v["child_frame_id"] == child).expect("transform at the middle sample");
        assert_eq!(v["parent_frame_id"], "world");
        for (axis, want) in ["x", "y", "z"].iter().zip(p) {
            let got = v["translation"][axis].as_f64().expect("translation");
            assert!((got - want).abs() <= 0.6e-4, "{child}.{axis}: {got} vs {want}");
        }
    }
}
