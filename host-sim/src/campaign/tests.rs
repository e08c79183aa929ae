//! Tests of the campaign loader, runner, statistics and CSV.

use super::*;

#[test]
fn percentiles_by_hand() {
    let p = percentiles((1..=101).map(f64::from).collect()).unwrap();
    assert_eq!((p.min, p.p5, p.p50, p.p95, p.max), (1.0, 6.0, 51.0, 96.0, 101.0));
    assert!(percentiles(vec![f64::NAN]).is_none());
}

/// `sweep --replay-worst`: the re-flown run is the worst row's flight (same summary, wall
/// time aside), and it has the time histories the replay needs.
#[test]
fn refly_repeats_the_worst_run_with_a_record() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/experiment-3uav.toml");
    let c = load(Some(&path)).unwrap();
    let rows = fly(&c, 3, 7, 1, false).unwrap();
    let w = worst(&rows).unwrap();
    let least = rows.iter().map(|r| r.summary.min_uav_boundary_m).fold(f64::INFINITY, f64::min);
    assert!(rows.iter().all(|r| r.summary.success), "a failed row would be the worst");
    assert_eq!(w.summary.min_uav_boundary_m, least);
    let o = refly(&c, w).unwrap();
    let strip = |s: &Summary| Summary { wall_time_s: 0.0, realtime_factor: 0.0, ..s.clone() };
    assert_eq!(strip(&o.summary), strip(&w.summary));
    assert!(!o.record.time_s.is_empty() && o.record.uav_pos_m.len() == o.record.time_s.len());
    // A failure comes first whatever the distances.
    let mut failed = rows.clone();
    failed[2].summary.success = false;
    failed[2].summary.min_uav_boundary_m = 99.0;
    assert_eq!(worst(&failed).map(|r| r.summary.seed), Some(failed[2].summary.seed));
    // A run that left the tube comes before any other failure, even refused on the ground.
    let mut out = failed.clone();
    out[1].summary.min_load_boundary_m = -0.3;
    out[1].summary.outcome = "refused".into();
    assert_eq!(worst(&out).map(|r| r.summary.seed), Some(out[1].summary.seed));
    // Nothing flown (refused before take-off): never picked.
    out[1].summary.sim_time_s = 0.0;
    assert_eq!(worst(&out).map(|r| r.summary.seed), Some(out[2].summary.seed));
    assert!(worst(&[]).is_none());
}

#[test]
fn merge_overrides_nested_tables() {
    let mut a: toml::Table = toml::from_str("[x]\na = 1\nb = 2\n[y]\nc = 3").unwrap();
    let b: toml::Table = toml::from_str("[x]\nb = 5\n[z]\nd = 1").unwrap();
    merge_tables(&mut a, &b);
    assert_eq!(a["x"]["a"].as_integer(), Some(1));
    assert_eq!(a["x"]["b"].as_integer(), Some(5));
    assert_eq!(a["z"]["d"].as_integer(), Some(1));
    assert!(set_dotted(&mut a, "x.e", 0.5));
    assert_eq!(a["x"]["e"].as_float(), Some(0.5));
    let mut f: toml::Table = toml::from_str("[[faults]]\nuav = 0\n").unwrap();
    assert!(set_dotted(&mut f, "faults.0.uav", 3.0));
    assert_eq!(f["faults"][0]["uav"].as_integer(), Some(3));
    assert!(!set_dotted(&mut f, "faults.5.uav", 3.0));
}

#[test]
fn a_campaign_overrides_one_field_of_a_table_its_base_lacks() {
    // Issue 29: `[link] drop_probability` over experiment-3uav.toml (no `[link]`) failed
    // with "missing field `delay_s`". Every field of an optional table has its default.
    let base = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/experiment-3uav.toml");
    let base_text = std::fs::read_to_string(&base).unwrap();
    assert!(!base_text.contains("[link]") && !base_text.contains("[baseline]"), "the base must lack both tables");
    let dir = std::env::temp_dir().join(format!("vt-campaign-merge-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("drops.toml");
    let text = format!("base = {:?}\nruns = 2\n[link]\ndrop_probability = 0.1\n[baseline]\nk1 = 1.5\n", base.display().to_string());
    std::fs::write(&file, text).unwrap();
    let c = load(Some(&file)).unwrap_or_else(|e| panic!("{e}"));
    let s = &c.levels[0].1.scenario;
    assert_eq!(s.link.drop_probability, 0.1);
    assert_eq!(s.link.delay_s, 0.0, "absent: its documented default");
    assert_eq!(s.link.stale_timeout_s, 0.5, "absent: its documented default");
    assert_eq!(s.baseline.k1, 1.5);
    assert_eq!((s.baseline.k2, s.baseline.v_max_mps), (1.0, 3.0), "absent: the published values");
    // A plain scenario file with a partial table parses the same way.
    let partial = crate::scenario::parse(&(base_text + "\n[link]\ndelay_s = 0.04\n"), "partial.toml").unwrap_or_else(|e| panic!("{e}"));
    assert_eq!((partial.scenario.link.delay_s, partial.scenario.link.drop_probability), (0.04, 0.0));
    let _ = std::fs::remove_dir_all(&dir);
}

/// A campaign gives the take-off layout one way (a ring's radius or one node per cable) and
/// replaces the base's other way, as it does for the tube (plan or waypoints): both at once
/// would be refused.
#[test]
fn a_campaign_s_take_off_layout_replaces_the_base_s() {
    let scenarios = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios");
    let dir = std::env::temp_dir().join(format!("vt-campaign-layout-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let packed = load(Some(&scenarios.join("campaigns/payload-packed.toml"))).unwrap_or_else(|e| panic!("{e}"));
    let u = &packed.levels[0].1.scenario.uavs;
    assert!(u.formation_radius_m.is_none() && u.formation_offsets_m.as_ref().is_some_and(|o| o.len() == 10), "the paper's ring replaced");
    let file = dir.join("ring.toml");
    let base = scenarios.join("heavy-25uav.toml").display().to_string();
    std::fs::write(&file, format!("base = {base:?}\nworld = \"scenario\"\n[uavs]\nformation_radius_m = 6.2\n")).unwrap();
    let ring = load(Some(&file)).unwrap_or_else(|e| panic!("{e}"));
    let u = &ring.levels[0].1.scenario.uavs;
    assert!(u.formation_offsets_m.is_none() && u.formation_radius_m == Some(6.2), "the two rings replaced");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Issue 29: `generate = true` flies each run on the scenario generated from its seed over
/// the level's table: rows carry the class, the same seeds give the same rows, a refly is
/// the same flight, shards merge to the whole, and per-class tables cover every row.
#[test]
fn a_generated_campaign_flies_one_generated_scenario_per_seed() {
    let dir = std::env::temp_dir().join(format!("vt-campaign-gen-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("gen.toml");
    let text = "base = \"builtin:paper-10uav\"\ngenerate = true\nruns = 3\nseed = 5003\n[disturbances]\nposition_noise_m = 0.02\n";
    // (builtin base: paths relative to nothing.)
    std::fs::write(&file, text).unwrap();
    let c = load(Some(&file)).unwrap_or_else(|e| panic!("{e}"));
    assert!(c.generate && c.name.starts_with("generated over"));
    let rows = fly(&c, c.runs, c.seed, 2, false).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(rows.len(), 3);
    for (r, seed) in rows.iter().zip(5003..) {
        let class = r.class.as_ref().expect("a generated row has its class");
        assert_eq!(r.summary.scenario, format!("gen-{seed}"));
        assert_eq!(r.summary.n_uavs, class.n_uavs);
        assert_eq!(r.summary.seed, seed);
    }
    // (Compared through sweep.csv: everything but the wall-clock time.)
    assert_eq!(csv(&rows), csv(&fly(&c, c.runs, c.seed, 1, false).unwrap_or_else(|e| panic!("{e}"))), "deterministic whatever the threads");
    let again = refly(&c, &rows[1]).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(again.summary.min_uav_uav_m.to_bits(), rows[1].summary.min_uav_uav_m.to_bits());
    // Sharded through JSON, as between machines.
    let shards: Vec<(String, ShardFile)> = [2, 1]
        .iter()
        .map(|&k| {
            let spec = ShardSpec { index: k, count: 2 };
            let part = fly_shard(&c, c.runs, c.seed, 1, false, Some(spec)).unwrap_or_else(|e| panic!("{e}"));
            let text = serde_json::to_string(&ShardFile::new(&c, c.runs, c.seed, spec, part)).unwrap_or_default();
            (format!("shard{k}"), serde_json::from_str::<ShardFile>(&text).unwrap_or_else(|e| panic!("{e}")))
        })
        .collect();
    assert_eq!(csv(&merge(&shards).unwrap_or_else(|e| panic!("{e}")).rows), csv(&rows));
    let rep = report(&c, c.seed, &rows);
    for dim in ["tube", "airframe", "team", "load"] {
        assert_eq!(rep.classes.iter().filter(|k| k.dimension == dim).map(|k| k.runs).sum::<usize>(), 3, "{dim}");
    }
    assert_eq!(rep.levels[0].out_of_tube, rows.iter().filter(|r| left_the_tube(&r.summary)).count());
    assert!(csv(&rows).lines().nth(1).is_some_and(|l| l.contains(&rows[0].class.as_ref().map_or(String::new(), |k| k.airframe.clone()))));
    // A bad flag names its key.
    std::fs::write(&file, "base = \"builtin:paper-10uav\"\ngenerate = \"yes\"\n").unwrap();
    let e = load(Some(&file)).unwrap_err();
    assert_eq!(e.field.as_deref(), Some("generate"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Issue 29: `declare_wind = true` declares each run's forecast (mean + two gust sigma at the
/// level's intensity); the experiment's team (capacity 7.6 m/s) is refused at 3x of a
/// 3 m/s + 0.5 m/s-sigma wind (10.5 m/s) and flies at 1x (4.0 m/s). Refused rows fly
/// nothing, are counted, and are never the run `--replay-worst` picks.
#[test]
fn declared_wind_refuses_the_runs_the_team_cannot_hold() {
    let base = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/experiment-3uav.toml");
    let dir = std::env::temp_dir().join(format!("vt-campaign-wind-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("windy.toml");
    let text = format!(
        "base = {:?}\ndeclare_wind = true\nruns = 2\nseed = 3\n[disturbances]\nwind_mean_mps = [3.0, 0.0, 0.0]\ngust_std_mps = 0.5\n[mission]\ntime_limit_s = 4.0\n[levels]\nkey = \"disturbances.intensity\"\nvalues = [1.0, 3.0]\n",
        base.display().to_string()
    );
    std::fs::write(&file, text).unwrap();
    let c = load(Some(&file)).unwrap_or_else(|e| panic!("{e}"));
    assert!(c.declare_wind && !c.generate);
    let rows = fly(&c, c.runs, c.seed, 2, false).unwrap_or_else(|e| panic!("{e}"));
    for r in &rows {
        let refused = r.level == Some(3.0);
        assert_eq!(r.summary.was_refused(), refused, "{:?}", r.summary.failures);
        if refused {
            assert_eq!(r.summary.sim_time_s, 0.0, "nothing flew");
            assert!(r.summary.failures[0].starts_with("refused before take-off: ") && r.summary.failures[0].contains("capacity 7.6 m/s"), "{:?}", r.summary.failures);
        } else {
            assert!(r.summary.sim_time_s > 0.0 && r.summary.outcome == "flown");
        }
    }
    let rep = report(&c, c.seed, &rows);
    assert_eq!((rep.levels[0].refused, rep.levels[1].refused), (0, 2));
    assert!(worst(&rows).is_some_and(|w| !w.summary.was_refused()));
    let _ = std::fs::remove_dir_all(&dir);
}

/// Issue 27 §5: a campaign flies its base in the real-aircraft world by default: ground start,
/// PX4's stock gains with the matched observer lag, the airframe's envelope declared, the
/// formation shaped, RTK errors, the attitude estimate, light turbulence, thrust errors and
/// the 0.2 m floor. The campaign's own tables still win; `world = "scenario"` (or the
/// command line's override) flies the base as written; a point-mass base keeps its world.
#[test]
fn campaigns_fly_the_real_aircraft_world_unless_told_otherwise() {
    use crate::scenario::{AutopilotPreset, MissionStart};
    use crate::sensing::{AttitudeModel, PositionModel};
    let scenarios = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios");
    let dir = std::env::temp_dir().join(format!("vt-campaign-world-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let write = |name: &str, base: &str, rest: &str| {
        let file = dir.join(name);
        std::fs::write(&file, format!("base = {:?}\nruns = 2\n{rest}", scenarios.join(base).display().to_string())).unwrap();
        file
    };
    let plain = write("plain.toml", "experiment-3uav.toml", "[disturbances]\nposition_noise_m = 0.02\n");
    let c = load(Some(&plain)).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(c.world, World::RealAircraft);
    assert!(c.name.ends_with("in the real-aircraft world"), "{}", c.name);
    let s = &c.levels[0].1.scenario;
    assert_eq!(s.mission.start, MissionStart::Ground);
    assert_eq!(s.mission.clearance_floor_m, Some(world::CLEARANCE_FLOOR_M));
    assert_eq!(s.uavs.autopilot, AutopilotPreset::Px4Default);
    let envelope = crate::quadrotor::QuadParams::sized(s.uavs.mass_kg, s.uavs.thrust_max_n).envelope_radius_m();
    assert_eq!(s.uavs.body_radius_m, Some(envelope));
    assert!((envelope - 0.404).abs() < 1e-3, "the 1.47 kg airframe: {envelope}");
    assert!(s.controller.shape.enabled);
    assert_eq!(
        (s.controller.share_gain_mps_per_n, s.controller.load_altitude_gain_per_s, s.controller.share_offset_max_m),
        (world::SHARE_GAIN_MPS_PER_N, world::LOAD_ALTITUDE_GAIN_PER_S, world::SHARE_OFFSET_MAX_M),
        "load sharing on"
    );
    // The observer's lag matched to the 1.47 kg airframe behind the stock gains (the paper's
    // 2 kg one keeps 0.08 s; vt_sim::observer_lag).
    let lag = vt_sim::observer_lag::stock_observer_lag_s(s.uavs.mass_kg, s.uavs.thrust_max_n);
    assert_eq!(s.velocity_loop.rigid_body.and_then(|t| t.actuator_lag_s), Some(lag));
    assert!(lag > world::STOCK_AUTOPILOT_LAG_S, "{lag}");
    assert_eq!((s.sensing.position, s.sensing.attitude), (PositionModel::Rtk, AttitudeModel::Px4));
    assert_eq!((s.disturbances.turbulence, s.disturbances.thrust_scale_error), (world::TURBULENCE, world::THRUST_SCALE_ERROR));
    assert_eq!(s.disturbances.position_noise_m, 0.02, "the campaign's own disturbances stay");

    // The campaign's keys win over the world's.
    let air = write("air.toml", "experiment-3uav.toml", "[mission]\nstart = \"air\"\n[uavs]\nautopilot = \"tuned\"\nbody_radius_m = 0.5\n");
    let s = load(Some(&air)).unwrap_or_else(|e| panic!("{e}")).levels[0].1.scenario.clone();
    assert_eq!((s.mission.start, s.uavs.autopilot, s.uavs.body_radius_m), (MissionStart::Air, AutopilotPreset::Tuned, Some(0.5)));
    assert_eq!(s.sensing.position, PositionModel::Rtk, "the rest of the world stays");

    // As written: by the file's key, or by the command line over it.
    let as_written = crate::scenario::load(Some(&scenarios.join("experiment-3uav.toml"))).unwrap_or_else(|e| panic!("{e}")).scenario;
    let keyed = write("keyed.toml", "experiment-3uav.toml", "world = \"scenario\"\n");
    for c in [load(Some(&keyed)), load_in(Some(&plain), Some(World::Scenario))] {
        let c = c.unwrap_or_else(|e| panic!("{e}"));
        let s = &c.levels[0].1.scenario;
        assert_eq!(c.world, World::Scenario);
        assert_eq!((s.mission.start, s.uavs.autopilot, s.uavs.body_radius_m), (as_written.mission.start, as_written.uavs.autopilot, None));
        assert_eq!((s.sensing.position, s.disturbances.turbulence), (PositionModel::White, 0.0));
    }
    assert_eq!(load_in(Some(&keyed), Some(World::RealAircraft)).unwrap_or_else(|e| panic!("{e}")).world, World::RealAircraft);

    // A point-mass base keeps its own world; a plain scenario file flies as written.
    let pm = write("pm.toml", "paper-10uav.toml", "[uavs]\nmodel = \"point_mass\"\n");
    let s = load(Some(&pm)).unwrap_or_else(|e| panic!("{e}")).levels[0].1.scenario.clone();
    assert_eq!((s.mission.start, s.sensing.position, s.uavs.body_radius_m), (MissionStart::Air, PositionModel::White, None));
    assert_eq!(load(Some(&scenarios.join("experiment-3uav.toml"))).unwrap_or_else(|e| panic!("{e}")).world, World::Scenario);

    // A bad name is an error naming the key.
    let bad = write("bad.toml", "experiment-3uav.toml", "world = \"mars\"\n");
    let e = load(Some(&bad)).unwrap_err();
    assert_eq!(e.field.as_deref(), Some("world"), "{e}");
    assert!(e.to_string().contains("mars") && e.to_string().contains("real_aircraft"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `scenarios/campaigns/real-world.toml` spells the real-aircraft world out: flown as written,
/// its scenario at each level is the one the world's table gives the nominal campaign's
/// disturbances (with its bodies' 0.445 m, the envelope rounded).
#[test]
fn the_real_world_campaign_is_the_real_aircraft_world_spelled_out() {
    let campaigns = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/campaigns");
    let spelled = load_in(Some(&campaigns.join("real-world.toml")), Some(World::Scenario)).unwrap_or_else(|e| panic!("{e}"));
    let dir = std::env::temp_dir().join(format!("vt-campaign-real-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("nominal-real.toml");
    let text = format!(
        "base = {:?}\nruns = 200\nseed = 1000\n[levels]\nkey = \"disturbances.intensity\"\nvalues = [1.0, 3.0]\n[uavs]\nbody_radius_m = 0.445\n\
         [link]\ndrop_probability = 0.10\n[disturbances]\nposition_noise_m = 0.05\nvelocity_noise_mps = 0.05\nlatency_s = 0.02\nlink_jitter_s = 0.02\n\
         wind_mean_mps = [3.0, 0.0, 0.0]\ngust_std_mps = 1.0\ngust_tau_s = 2.0\n",
        campaigns.join("../paper-10uav.toml").display().to_string()
    );
    std::fs::write(&file, text).unwrap();
    let world = load(Some(&file)).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(world.levels.len(), spelled.levels.len());
    for ((la, a), (lb, b)) in world.levels.iter().zip(&spelled.levels) {
        assert_eq!(la, lb);
        assert_eq!(format!("{:?}", a.scenario), format!("{:?}", b.scenario), "level {la:?}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
