//! `host-sim sitl --plant rotorpy` (issue 26): the mission flown in RotorPy (Folk et al. 2023,
//! PyPI `rotorpy`), a simulator nobody here wrote, by unchanged `vt-companion` processes.
//!
//! host-sim is only the ground station and the referee here: it writes the plant's
//! configuration (`rotorpy_config.json`: the airframe it sizes, the take-off state, cables,
//! wind, the tube's samples for the stop), starts `vt-sim/rotorpy/vt_rotorpy.py` (the plant,
//! speaking the lockstep MAVLink protocol of `host-sim serve` through pymavlink) and one
//! `vt-companion` per UAV, uploads the scenario and starts the mission with its ground station,
//! and scores the trajectory the plant writes with [`crate::score`]. docs/plant.md sets the
//! figures beside host-sim's rigid body.

use super::gcs::Gcs;
use super::{CompanionProcess, SitlReport};
use crate::lockstep::{self, PilError};
use crate::quadrotor::QuadParams;
use crate::scenario::LoadedScenario;
use crate::score::{score_file, Provenance};
use crate::sim::{self, RunOptions, RunOutput};
use serde_json::json;
use std::io::{BufRead, BufReader, Write};
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};
use std::time::Instant;

/// The plant program, in the source tree.
pub fn plant_script() -> PathBuf {
    std::env::var_os("VT_ROTORPY_SCRIPT")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("rotorpy").join("vt_rotorpy.py"))
}

/// The Python that has RotorPy: `$VT_PYTHON`, else the project's environment
/// (`target/rotorpy-venv`, made by `scripts/test-all.sh`), else `python3`.
pub fn python() -> PathBuf {
    if let Some(p) = std::env::var_os("VT_PYTHON") {
        return PathBuf::from(p);
    }
    let venv = Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/rotorpy-venv/bin/python");
    if venv.is_file() { venv } else { PathBuf::from("python3") }
}

/// Why a scenario cannot fly in RotorPy, if it cannot: the plant models the scenario's
/// airframe, cables, load and wind, not the link, sensing or fault models host-sim adds.
pub fn unsupported(ls: &LoadedScenario) -> Option<String> {
    let s = &ls.scenario;
    let d = &s.disturbances;
    let mut what = Vec::new();
    if !s.faults.is_empty() {
        what.push("[[faults]]");
    }
    if s.link.delay_s != 0.0 || s.link.drop_probability != 0.0 {
        what.push("[link] delay or drops");
    }
    if d.intensity != 0.0 && (d.position_noise_m != 0.0 || d.velocity_noise_mps != 0.0 || d.latency_s != 0.0 || d.link_jitter_s != 0.0) {
        what.push("[disturbances] sensing noise, latency or jitter");
    }
    if d.intensity != 0.0
        && (d.cable_length_error != 0.0 || d.cable_stiffness_error != 0.0 || d.uav_mass_error != 0.0 || d.load_mass_error != 0.0 || d.thrust_scale_error != 0.0)
    {
        what.push("[disturbances] parameter errors");
    }
    if d.intensity != 0.0 && d.turbulence != 0.0 {
        what.push("[disturbances] turbulence");
    }
    if s.uavs.battery_sag_per_min != 0.0 {
        what.push("[uavs] battery_sag_per_min");
    }
    if s.uavs.autopilot != crate::scenario::AutopilotPreset::Tuned {
        what.push("[uavs] autopilot (RotorPy flies its own attitude controller)");
    }
    if s.sensing.position != crate::sensing::PositionModel::White {
        what.push("[sensing] position");
    }
    if s.sensing.attitude != crate::sensing::AttitudeModel::True {
        what.push("[sensing] attitude (RotorPy flies its own attitude controller)");
    }
    if s.mission.start != crate::scenario::MissionStart::Air {
        what.push("[mission] start (the RotorPy bridge has no ground)");
    }
    (!what.is_empty()).then(|| {
        format!("{}: the RotorPy plant models the airframe, cables, load and wind only; remove {} (or fly --plant host)", ls.source_name, what.join(", "))
    })
}

/// The plant's configuration (`rotorpy_config.json`).
fn config(ls: &LoadedScenario, rated_n: f64, trajectory: &Path) -> serde_json::Value {
    let s = &ls.scenario;
    let n = s.cables.lengths_m.len();
    let to = sim::takeoff(s, &ls.tube, rated_n);
    let q = QuadParams::sized(s.uavs.mass_kg, s.uavs.thrust_max_n);
    let attach = [q.attach_point_body_m.x, q.attach_point_body_m.y, q.attach_point_body_m.z];
    // The take-off positions are the cable hooks (host-sim's plant puts the centre of mass
    // above them, level): the centre of mass is the hook less the hook's offset.
    let com: Vec<[f64; 3]> = to.uav_pos_m.iter().map(|p| [p.x - attach[0], p.y - attach[1], p.z - attach[2]]).collect();
    let r = &s.rates;
    let ll_every = u64::from(r.plant_hz / r.low_level_hz);
    let boot_steps = crate::mission::world::preflight_steps(s);
    let d = &s.disturbances;
    // The tube's samples are equally spaced in arc length.
    let ds = ls.tube.ds_m();
    let samples: Vec<[f32; 3]> = ls.tube.samples().iter().enumerate().map(|(k, p)| [p.pos_m.x, p.pos_m.y, k as f32 * ds]).collect();
    json!({
        "scenario": s.name,
        "system_ids": (0..n).map(|i| crate::companion::SYSID_BASE.saturating_add(i as u8)).collect::<Vec<u8>>(),
        "load_component": crate::companion::LOAD_COMPONENT_ID,
        // RotorPy's adaptive integrator takes one plant step per low-level period: the
        // setpoints are held over it anyway, and the cable acts inside its derivative.
        "rates": { "plant_hz": r.low_level_hz, "low_level_hz": r.low_level_hz, "high_level_hz": r.high_level_hz },
        "preflight_periods": boot_steps / ll_every,
        "time_limit_s": s.mission.time_limit_s,
        "post_arrival_s": s.mission.post_arrival_s,
        "airframe": {
            "mass_kg": q.mass_kg,
            "inertia_kgm2": [q.inertia_kgm2.x, q.inertia_kgm2.y, q.inertia_kgm2.z],
            "arm_m": q.arm_length_m,
            "k_eta": q.thrust_coeff_n_per_rps2,
            "yaw_moment_m": q.yaw_moment_coeff_m,
            "rotor_drag": q.rotor_drag_coeff,
            "body_drag": [q.body_drag_n_per_mps2.x, q.body_drag_n_per_mps2.y, q.body_drag_n_per_mps2.z],
            "motor_tau_s": q.motor_time_constant_s,
            "rotor_thrust_min_n": q.rotor_thrust_min_n,
            "rotor_thrust_max_n": q.rotor_thrust_max_n,
            "thrust_max_n": s.uavs.thrust_max_n,
            "attach_body_m": attach,
            // The heading the companions hold (VL_YAW = 0: NED north, ENU +y).
            "heading_enu_rad": std::f64::consts::FRAC_PI_2,
        },
        "cables": {
            "lengths_m": s.cables.lengths_m,
            "stiffness_n_per_m": vec![s.cables.stiffness_n_per_m; n],
            "damping_ns_per_m": s.cables.damping_ns_per_m,
            "breaking_n": s.cables.breaking_strength_n(),
        },
        "load": { "mass_kg": s.load.plant_mass_kg(), "drag_area_m2": d.load_drag_area_m2 },
        "wind": {
            "mean_mps": [d.wind_mean_mps[0] * d.intensity, d.wind_mean_mps[1] * d.intensity, d.wind_mean_mps[2] * d.intensity],
            "gust_std_mps": d.gust_std_mps * d.intensity,
            "gust_tau_s": d.gust_tau_s,
            "surface_roughness_m": d.surface_roughness_m,
            "seed": s.seed,
        },
        "start": { "uav_pos_m": com, "load_pos_m": [to.load_pos_m.x, to.load_pos_m.y, to.load_pos_m.z] },
        "tube": { "samples": samples, "end_s_m": f64::from(ls.tube.length_m()) - s.mission.end_tolerance_m },
        "trajectory": trajectory,
    })
}

/// The plant process and its control lines.
struct PlantProcess {
    child: Child,
    stdin: ChildStdin,
    stdout: BufReader<ChildStdout>,
}

impl PlantProcess {
    fn spawn(config: &Path) -> Result<Self, PilError> {
        let py = python();
        let script = plant_script();
        let mut child = Command::new(&py)
            .arg(&script)
            .arg(config)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .map_err(|e| PilError(format!("{}: {e} (RotorPy needs a Python with `rotorpy` and `pymavlink`: set VT_PYTHON or run scripts/test-all.sh)", py.display())))?;
        let (Some(stdin), Some(stdout)) = (child.stdin.take(), child.stdout.take()) else {
            return Err(PilError("RotorPy plant: no pipes".into()));
        };
        Ok(Self { child, stdin, stdout: BufReader::new(stdout) })
    }

    fn line(&mut self) -> Result<String, PilError> {
        let mut l = String::new();
        match self.stdout.read_line(&mut l) {
            Ok(0) | Err(_) => {
                let status = self.child.wait().map(|s| s.to_string()).unwrap_or_default();
                Err(PilError(format!("the RotorPy plant stopped ({status}); its messages are above")))
            }
            Ok(_) => Ok(l.trim().to_string()),
        }
    }

    fn say(&mut self, what: &str) -> Result<(), PilError> {
        writeln!(self.stdin, "{what}").and_then(|()| self.stdin.flush()).map_err(|e| PilError(format!("RotorPy plant: {e}")))
    }
}

impl Drop for PlantProcess {
    fn drop(&mut self) {
        if let Ok(None) = self.child.try_wait() {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

/// Checks that the Python environment has RotorPy and pymavlink.
///
/// # Errors
/// It does not, with the command that installs them.
pub fn check_python() -> Result<(), PilError> {
    let py = python();
    let ok = Command::new(&py).args(["-c", "import rotorpy, pymavlink"]).stdout(Stdio::null()).stderr(Stdio::null()).status().is_ok_and(|s| s.success());
    if ok {
        Ok(())
    } else {
        Err(PilError(format!(
            "{} cannot import rotorpy and pymavlink: `python3 -m venv target/rotorpy-venv && target/rotorpy-venv/bin/pip install rotorpy==3.0.0 pymavlink` (scripts/test-all.sh does it), or set VT_PYTHON",
            py.display()
        )))
    }
}

/// Flies `ls` in RotorPy with one `vt-companion` process per UAV (lockstep), the plant's
/// files in `out`.
///
/// # Errors
/// A process or socket failed, a companion refused the start, or the trajectory cannot be scored.
pub fn sitl_rotorpy(ls: &LoadedScenario, opts: &RunOptions, bin: &Path, out: &Path) -> Result<(RunOutput, SitlReport), PilError> {
    check_python()?;
    let s = &ls.scenario;
    let n = s.cables.lengths_m.len();
    std::fs::create_dir_all(out).map_err(|e| PilError(format!("{}: {e}", out.display())))?;
    let trajectory = out.join("rotorpy_trajectory.csv");
    let config_path = out.join("rotorpy_config.json");
    let rated = opts.f_max_n.unwrap_or(s.cables.rated_n);
    let text = serde_json::to_string_pretty(&config(ls, rated, &trajectory)).map_err(|e| PilError(e.to_string()))?;
    std::fs::write(&config_path, text).map_err(|e| PilError(format!("{}: {e}", config_path.display())))?;
    let wall = Instant::now();
    let mut plant = PlantProcess::spawn(&config_path)?;
    let ports_line = plant.line()?;
    let ports: Vec<SocketAddr> = ports_line
        .strip_prefix("PORTS ")
        .map(|p| p.split_whitespace().filter_map(|x| x.parse::<u16>().ok()).map(|p| SocketAddr::from(([127, 0, 0, 1], p))).collect())
        .unwrap_or_default();
    if ports.len() != n {
        return Err(PilError(format!("RotorPy plant: expected {n} ports, got `{ports_line}`")));
    }
    let loopback: SocketAddr = ([127, 0, 0, 1], 0).into();
    let mut gcs = Gcs::bind(loopback, Vec::new())?;
    let gcs_addr = gcs.local_addr()?;
    let procs = ports.iter().map(|p| CompanionProcess::spawn(bin, &[*p, gcs_addr])).collect::<Result<Vec<_>, _>>()?;
    gcs.set_endpoints(procs.iter().map(|p| p.addr).collect());
    let setup = lockstep::team_setup_for(ls, opts.controller, sim::takeoff(s, &ls.tube, rated), rated, true)?;
    gcs.upload(&setup.configs)?;
    plant.say("FLY")?;
    let start = plant.line()?;
    if start != "START" {
        return Err(PilError(format!("RotorPy plant: expected START, got `{start}`")));
    }
    let ids: Vec<u8> = setup.configs.iter().map(|c| c.system_id).collect();
    let results = gcs.start(&ids)?;
    if let Some((i, (r, texts))) = results.iter().enumerate().find(|(_, (r, _))| *r != 0) {
        let _ = plant.say("ABORT");
        return Err(PilError(format!("UAV {i} refused the start (MAV_RESULT {r}): {}", texts.join("; "))));
    }
    plant.say("GO")?;
    let done = plant.line()?;
    let Some(rest) = done.strip_prefix("DONE ") else {
        return Err(PilError(format!("RotorPy plant: expected DONE, got `{done}`")));
    };
    let plant_wall_s: f64 = rest.split_whitespace().nth(1).and_then(|w| w.parse().ok()).unwrap_or(0.0);
    let _ = plant.child.wait();
    let codes: Vec<Option<i32>> = procs.into_iter().map(|p| p.stop().0).collect();
    let from = Provenance { plant: "rotorpy", uav_model: "rotorpy_multirotor", cable_model: "elastic", controller: opts.controller, wall_s: plant_wall_s };
    let (summary, record) = score_file(&trajectory, ls, &from).map_err(|e| PilError(e.0))?;
    let report = SitlReport {
        scenario: s.name.clone(),
        n_uavs: n,
        mode: "lockstep (RotorPy plant)".into(),
        commands_compared: 0,
        bit_exact: None,
        max_abs_diff: 0.0,
        first_difference: None,
        summary: summary.clone(),
        wall_time_s: [wall.elapsed().as_secs_f64(), 0.0],
        lockstep_overhead: 0.0,
        companion_exit_codes: codes,
    };
    Ok((RunOutput { summary, record, scene: sim::scene(ls) }, report))
}
