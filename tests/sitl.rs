//! Issue 26: host-sim as a MAVLink simulator. Real `vt-companion` processes over real UDP
//! sockets, configured and started by the ground station: in lockstep bit for bit the SIL
//! twin's commands; on the wall clock the mission succeeds with its floors; the ground
//! station's start, hold, resume, abort, status and verbatim refusals.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic, clippy::indexing_slicing)]

use host_sim::pil::{self, Encoders, Port, TickFrames};
use host_sim::scenario::{self, LoadedScenario};
use host_sim::sim::{self, RunOptions};
use host_sim::sitl::gcs::{Gcs, GcsCommand};
use host_sim::sitl::udp::UdpPort;
use host_sim::sitl::{self, CompanionProcess};
use nalgebra::Vector3;
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use vt_companion::{HoldReasons, Mode, Param};

type V3f = Vector3<f32>;

/// The processes of these tests share two cores: one test at a time.
static SERIAL: Mutex<()> = Mutex::new(());

fn experiment() -> LoadedScenario {
    scenario::load(Some(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/experiment-3uav.toml"))).unwrap()
}

/// The `vt-companion` that `cargo test --workspace` built beside this test (`target/<profile>/`).
fn companion() -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    let beside = exe.parent().and_then(Path::parent).map(|d| d.join("vt-companion")).filter(|p| p.is_file());
    beside.unwrap_or_else(|| sitl::companion_binary().expect("vt-companion"))
}

#[test]
fn sitl_lockstep_experiment_is_bit_exact_with_the_sil_twin() {
    let _one = SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let ls = experiment();
    let opts = RunOptions { record: false, ..RunOptions::default() };
    let (run, report, commands) = sitl::sitl_lockstep(&ls, &opts, &companion()).expect("SITL flies");
    println!(
        "SITL lockstep, experiment-3uav: success {}, {} commands, bit-exact {:?}, UAV-bnd {:.3} m, UAV-UAV {:.3} m, wall {:.2} s vs SIL {:.2} s ({:.1}x), exits {:?}",
        run.summary.success,
        report.commands_compared,
        report.bit_exact,
        run.summary.min_uav_boundary_m,
        run.summary.min_uav_uav_m,
        report.wall_time_s[0],
        report.wall_time_s[1],
        report.lockstep_overhead,
        report.companion_exit_codes
    );
    assert!(run.summary.success, "{:?}", run.summary.failures);
    assert_eq!(report.bit_exact, Some(true), "first difference {:?}", report.first_difference);
    assert!(report.commands_compared > 50_000 && report.commands_compared == commands.len(), "{}", report.commands_compared);
    assert!(report.companion_exit_codes.iter().all(|c| *c == Some(0)), "each companion exits 0 after Ctrl-C: {:?}", report.companion_exit_codes);
    // The SIL team (companions called in process, no framing) flies the same mission.
    let sil = sim::run(&ls, &opts).unwrap().summary;
    assert_eq!((sil.min_uav_uav_m, sil.min_uav_boundary_m, sil.completion_time_s), (run.summary.min_uav_uav_m, run.summary.min_uav_boundary_m, run.summary.completion_time_s));
}

/// Issue 28 through the Linux companion: three `vt-companion` processes, configured by the
/// ground station with their map's `PR_*` parameters, get their LiDAR scans as
/// `OBSTACLE_DISTANCE` over UDP, re-plan aboard and push their tubes through host-sim's team
/// network: the re-route flown in lockstep bit for bit as the SIL twin, with its re-plans and
/// switches.
#[test]
fn sitl_lockstep_reroute_on_an_unknown_map_is_bit_exact_with_the_sil_twin() {
    let _one = SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let ls = scenario::load(Some(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/reroute-3uav-unknown.toml"))).unwrap();
    let opts = RunOptions { record: false, ..RunOptions::default() };
    let (run, report, _) = sitl::sitl_lockstep(&ls, &opts, &companion()).expect("SITL flies");
    let p = run.summary.perception.clone().expect("perception figures");
    println!("SITL lockstep, reroute-3uav-unknown: success {}, {} commands, bit-exact {:?}, {p:?}", run.summary.success, report.commands_compared, report.bit_exact);
    assert_eq!(report.bit_exact, Some(true), "first difference {:?}", report.first_difference);
    assert!(run.summary.success && p.replans > 0 && p.tube_switches > 0, "{:?} {p:?}", run.summary.failures);
    let sil = sim::run(&ls, &opts).unwrap().summary;
    assert_eq!(sil.perception, Some(p), "SIL's re-plans and switches");
}

#[test]
fn sitl_realtime_experiment_succeeds_with_its_floors() {
    let _one = SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let ls = experiment();
    let opts = RunOptions { record: false, ..RunOptions::default() };
    let (run, report) = sitl::sitl_realtime(&ls, &opts, &companion()).expect("SITL flies in real time");
    let s = &run.summary;
    let floor = ls.scenario.mission.safety_distance_m;
    println!(
        "SITL real time, experiment-3uav: success {} {:?}, completion {:?} s, UAV-bnd {:.3} m, UAV-UAV {:.3} m, wall {:.1} s, exits {:?}",
        s.success, s.failures, s.completion_time_s, s.min_uav_boundary_m, s.min_uav_uav_m, report.wall_time_s[0], report.companion_exit_codes
    );
    assert!(s.success, "{:?}", s.failures);
    assert!(s.min_uav_uav_m >= floor && s.min_uav_boundary_m >= floor, "floors {floor} m");
    assert_eq!(report.bit_exact, None, "two clocks: nothing to compare bit for bit");
    assert!(report.companion_exit_codes.iter().all(|c| *c == Some(0)), "{:?}", report.companion_exit_codes);
}

/// Issue 28 on the wall clock: three `vt-companion` processes on their own Tickers map the
/// LiDAR scans host-sim relays, the planner's search and the members' builds of its tubes run
/// on their planner threads (`Io::plans_aside`), and the team re-routes round the rocks. The
/// relay was missing from the real-time team at first, and the team flew the bounds-only tube
/// through the rocks while the summary said success: the clearance to the obstacles is held
/// here.
#[test]
fn sitl_realtime_reroute_on_an_unknown_map_goes_round_the_rocks() {
    let _one = SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let ls = scenario::load(Some(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/reroute-3uav-unknown.toml"))).unwrap();
    let opts = RunOptions { record: false, ..RunOptions::default() };
    let (run, report) = sitl::sitl_realtime(&ls, &opts, &companion()).expect("SITL flies in real time");
    let s = &run.summary;
    let p = s.perception.clone().expect("perception figures");
    println!("SITL real time, reroute-3uav-unknown: success {} {:?}, completion {:?} s, obstacles {:.3} m, {p:?}", s.success, s.failures, s.completion_time_s, s.min_obstacle_clearance_m);
    assert!(s.success, "{:?}", s.failures);
    assert!(p.replans > 0 && p.tube_switches > 0, "{p:?}");
    assert!(s.min_obstacle_clearance_m > 1.0, "bodies, load and cables clear of the rocks: {} m", s.min_obstacle_clearance_m);
    assert!(report.companion_exit_codes.iter().all(|c| *c == Some(0)), "{:?}", report.companion_exit_codes);
}

/// A feeder standing in for the three autopilots and the load tracker: every companion gets its
/// own state, the load's and the team's at 100 Hz (the take-off geometry, at rest), with
/// `SYSTEM_TIME`, on the wall clock.
fn feeder(ports: Vec<UdpPort>, setup: pil::TeamSetup, stop: Arc<AtomicBool>) -> std::thread::JoinHandle<Vec<UdpPort>> {
    std::thread::spawn(move || {
        let mut ports = ports;
        let f = |v: &Vector3<f64>| V3f::new(v.x as f32, v.y as f32, v.z as f32);
        let all: Vec<Option<host_sim::mission::Report>> = setup.takeoff.uav_pos_m.iter().map(|p| Some((f(p), V3f::zeros()))).collect();
        let load = f(&setup.takeoff.load_pos_m);
        let mut enc: Vec<Encoders> = (0..ports.len()).map(|_| Encoders::default()).collect();
        let t0 = Instant::now();
        while !stop.load(Ordering::Relaxed) {
            let time_ms = t0.elapsed().as_millis() as u32;
            for (i, port) in ports.iter_mut().enumerate() {
                let tick = TickFrames {
                    time_ms,
                    system_id: setup.configs[i].system_id,
                    load: Some((load, V3f::zeros())),
                    neighbours: &all,
                    own: all[i].unwrap(),
                    sample_ms: (time_ms, time_ms),
                    id: i,
                };
                let e = &mut enc[i];
                let _ = port.send(&tick.encode(&mut e.autopilot, &mut e.tracker, &mut e.network));
                while let Ok(Some(_)) = port.poll(Duration::ZERO) {}
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        ports
    })
}

/// The status of every UAV after `secs`, with `check` true for all, or the last table.
fn wait_status(g: &mut Gcs, secs: f64, check: impl Fn(&host_sim::sitl::gcs::UavStatus) -> bool) -> Result<(), String> {
    let t0 = Instant::now();
    loop {
        let st = g.poll_status(Duration::from_millis(200)).unwrap();
        if st.iter().all(&check) {
            return Ok(());
        }
        if t0.elapsed().as_secs_f64() > secs {
            return Err(host_sim::sitl::gcs::status_table(st));
        }
    }
}

#[test]
fn ground_station_uploads_starts_holds_resumes_aborts_and_shows_refusals_verbatim() {
    let _one = SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let ls = experiment();
    let loopback: SocketAddr = ([127, 0, 0, 1], 0).into();
    let mut ports: Vec<UdpPort> = (0..3).map(|_| UdpPort::bind(loopback, None, Duration::from_secs(5)).unwrap()).collect();
    let mut g = Gcs::bind(loopback, Vec::new()).unwrap();
    let bin = companion();
    let procs: Vec<CompanionProcess> = ports.iter().map(|p| CompanionProcess::spawn(&bin, &[p.local_addr().unwrap(), g.local_addr().unwrap()]).unwrap()).collect();
    for (p, c) in ports.iter_mut().zip(&procs) {
        p.set_peer(c.addr);
    }
    g.set_endpoints(procs.iter().map(|p| p.addr).collect());
    // On the wall clock (VT_LOCKSTEP = 0), as beside a real autopilot.
    let rated = ls.scenario.cables.rated_n;
    let mut setup = pil::team_setup_for(&ls, sim::ControllerKind::Dissipative, sim::takeoff(&ls.scenario, &ls.tube, rated), rated, false).unwrap();
    let ids: Vec<u8> = setup.configs.iter().map(|c| c.system_id).collect();
    // Refusal first: 6 kg declared, more than three 30 N UAVs lift.
    let mut heavy = setup.clone();
    for cfg in &mut heavy.configs {
        cfg.params.iter_mut().filter(|p| p.0 == Param::LoadKg).for_each(|p| p.1 = 6.0);
    }
    g.upload(&heavy.configs).expect("upload");
    let stop = Arc::new(AtomicBool::new(false));
    let feed = feeder(ports, setup.clone(), Arc::clone(&stop));
    wait_status(&mut g, 5.0, |s| s.heard && s.custom_mode & 0xFF == Mode::Ready as u32).expect("every companion ready after the upload");
    let refused = g.start(&ids).expect("answers");
    for (i, (r, texts)) in refused.iter().enumerate() {
        assert_eq!(*r, 2, "UAV {i}: MAV_RESULT_DENIED: {texts:?}");
        assert_eq!(texts.first().map(String::as_str), Some("start refused: team cannot lift the load"), "UAV {i}: verbatim");
        assert!(texts.get(1).is_some_and(|t| t.starts_with("need 58.9N have")), "UAV {i}: the numbers: {texts:?}");
    }
    // The right load, then the start.
    setup.configs.iter_mut().for_each(|c| c.params.retain(|p| p.0 == Param::LoadKg));
    g.upload(&setup.configs).expect("upload");
    let started = g.start(&ids).expect("answers");
    assert!(started.iter().all(|(r, _)| *r == 0), "{started:?}");
    wait_status(&mut g, 5.0, |s| s.custom_mode & 0xFF == Mode::Transport as u32 && s.tension_n.is_some_and(f32::is_finite) && s.clearance_m.is_some_and(|c| c > 0.0) && (0.0..200.0).contains(&s.ages_ms[0]))
        .unwrap_or_else(|t| panic!("transport with fresh data, a tension estimate and a clearance:\n{t}"));
    // Hold: every companion holds for the operator.
    assert_eq!(g.command(GcsCommand::Hold).unwrap(), vec![0, 0, 0]);
    wait_status(&mut g, 3.0, |s| s.custom_mode & 0xFF == Mode::Hold as u32 && (s.custom_mode >> 8) & u32::from(HoldReasons::OPERATOR) != 0)
        .unwrap_or_else(|t| panic!("operator hold:\n{t}"));
    // Resume: transport again after FS_RESUME.
    assert_eq!(g.command(GcsCommand::Resume).unwrap(), vec![0, 0, 0]);
    wait_status(&mut g, 5.0, |s| s.custom_mode & 0xFF == Mode::Transport as u32).unwrap_or_else(|t| panic!("resumed:\n{t}"));
    // Abort: the companions stop commanding (ready again; a second abort has nothing to stop).
    assert_eq!(g.command(GcsCommand::Abort).unwrap(), vec![0, 0, 0]);
    wait_status(&mut g, 3.0, |s| s.custom_mode & 0xFF == Mode::Ready as u32).unwrap_or_else(|t| panic!("aborted:\n{t}"));
    assert_eq!(g.command(GcsCommand::Abort).unwrap(), vec![1, 1, 1], "MAV_RESULT_TEMPORARILY_REJECTED: nothing to abort");
    stop.store(true, Ordering::Relaxed);
    drop(feed.join().unwrap());
    let codes: Vec<Option<i32>> = procs.into_iter().map(|p| p.stop().0).collect();
    assert_eq!(codes, vec![Some(0); 3]);
}

/// A free run of `n` consecutive loopback UDP ports (checked by binding them), the first one.
fn free_ports(n: u16) -> u16 {
    let seed = 20_000 + (std::process::id() % 20_000) as u16;
    (0..200u16)
        .map(|k| seed.wrapping_add(k * 37) % 40_000 + 20_000)
        .find(|&base| (0..n).all(|i| std::net::UdpSocket::bind(("127.0.0.1", base + i)).is_ok()))
        .expect("free ports")
}

/// What a person does: `host-sim serve` in one terminal, a `vt-companion` per UAV, and
/// `host-sim gcs ... upload` / `start` from another; the flight ends with the usual outputs.
#[test]
fn serve_and_the_gcs_command_fly_the_experiment_as_separate_programs() {
    let _one = SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let host_sim = env!("CARGO_BIN_EXE_host-sim");
    let scenario = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/experiment-3uav.toml");
    let out = std::env::temp_dir().join(format!("vt-serve-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let base = free_ports(3);
    // Any other free port for the ground station (the OS's choice, released for it).
    let gcs_port = std::iter::repeat_with(|| std::net::UdpSocket::bind("127.0.0.1:0").and_then(|s| s.local_addr()).unwrap().port())
        .find(|p| !(base..base + 3).contains(p))
        .unwrap();
    let mut serve = std::process::Command::new(host_sim)
        .args(["serve", scenario.to_str().unwrap(), "--port", &base.to_string(), "--out", out.to_str().unwrap()])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let lines = std::io::BufRead::lines(std::io::BufReader::new(serve.stderr.take().unwrap()));
    let (tx, rx) = std::sync::mpsc::channel::<String>();
    std::thread::spawn(move || lines.map_while(Result::ok).for_each(|l| drop(tx.send(l))));
    let wait_for = |needle: &str| {
        let t0 = Instant::now();
        while t0.elapsed() < Duration::from_secs(60) {
            if let Ok(l) = rx.recv_timeout(Duration::from_millis(100)) {
                if l.contains(needle) {
                    return;
                }
            }
        }
        panic!("serve never said {needle:?}");
    };
    wait_for("waiting for every companion to be configured");
    let gcs_addr: SocketAddr = ([127, 0, 0, 1], gcs_port).into();
    let bin = companion();
    let procs: Vec<CompanionProcess> = (0..3).map(|i| CompanionProcess::spawn(&bin, &[([127, 0, 0, 1], base + i).into(), gcs_addr]).unwrap()).collect();
    let team = procs.iter().map(|p| p.addr.to_string()).collect::<Vec<_>>().join(",");
    let gcs = |args: &[&str]| {
        let o = std::process::Command::new(host_sim).args(["gcs", "--team", &team, "--bind", &gcs_addr.to_string()]).args(args).output().unwrap();
        (o.status.code(), String::from_utf8_lossy(&o.stdout).into_owned() + &String::from_utf8_lossy(&o.stderr))
    };
    let (code, text) = gcs(&["upload", scenario.to_str().unwrap()]);
    assert_eq!(code, Some(0), "{text}");
    assert!(text.contains("tube accepted"), "{text}");
    wait_for("waiting for MAV_CMD_MISSION_START");
    let (code, text) = gcs(&["start"]);
    assert_eq!(code, Some(0), "{text}");
    assert_eq!(text.matches("MISSION_START accepted").count(), 3, "{text}");
    let t0 = Instant::now();
    let status = loop {
        if let Some(s) = serve.try_wait().unwrap() {
            break s;
        }
        assert!(t0.elapsed() < Duration::from_secs(120), "serve did not finish");
        std::thread::sleep(Duration::from_millis(100));
    };
    assert_eq!(status.code(), Some(0), "the mission succeeds");
    let summary: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["success"], serde_json::Value::Bool(true));
    let codes: Vec<Option<i32>> = procs.into_iter().map(|p| p.stop().0).collect();
    assert_eq!(codes, vec![Some(0); 3]);
    let _ = std::fs::remove_dir_all(&out);
}
