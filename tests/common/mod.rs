//! Test helpers shared by the backend comparisons (`tests/backends.rs`, `tests/failsafe.rs`),
//! the scenario error checks (`tests/wind.rs`, `tests/clearance.rs`), the generated missions
//! (`tests/ground_start.rs`, `tests/clearance.rs`) and the QEMU tests
//! (`tests/pil.rs`, `tests/perception_mcu.rs`).
#![allow(dead_code)] // each test target uses its own part

use host_sim::mission::{CompanionTeam, Setpoint, Team, TeamStart, Tick};
use host_sim::scenario::LoadedScenario;
use host_sim::sim::{ControllerKind, SimError};
use vt_dissipative::TeamMode;

/// The crates' team (`CompanionTeam`, dissipative), recording every setpoint as the twin's command
/// log does (`(step, uav, [qw, qx, qy, qz, thrust])`) and, at every high-level step, the team
/// modes it broadcasts; everything else is passed through.
pub struct Recording {
    pub team: CompanionTeam,
    pub commands: Vec<(u64, usize, Vec<f32>)>,
    pub modes: Vec<TeamMode>,
}

impl Recording {
    pub fn new() -> Self {
        Self { team: CompanionTeam::new(ControllerKind::Dissipative), commands: Vec::new(), modes: Vec::new() }
    }
}

impl Team for Recording {
    fn preflight(&mut self, ls: &LoadedScenario, at: &TeamStart<'_>) -> Result<(), SimError> {
        self.team.preflight(ls, at)
    }

    fn start(&mut self, ls: &LoadedScenario, start: &TeamStart<'_>) -> Result<Option<String>, SimError> {
        self.team.start(ls, start)
    }

    fn step(&mut self, tick: &Tick<'_>, out: &mut [Setpoint]) -> Result<(), SimError> {
        self.team.step(tick, out)?;
        for (i, sp) in out.iter().enumerate() {
            let [w, x, y, z] = sp.q_ned;
            self.commands.push((tick.step, i, vec![w, x, y, z, sp.thrust]));
        }
        if tick.high_level {
            let mut m = vec![TeamMode::Transport; out.len()];
            self.team.team_modes(&mut m);
            self.modes.extend(m);
        }
        Ok(())
    }

    fn invalid_commands(&self) -> u64 {
        self.team.invalid_commands()
    }

    fn holding(&self) -> Vec<bool> {
        self.team.holding()
    }

    fn team_modes(&self, out: &mut [TeamMode]) {
        self.team.team_modes(out);
    }

    fn phases(&self, phases: &mut [u8], refusals: &mut [u8]) {
        self.team.phases(phases, refusals);
    }

    fn refusal_text(&self, uav: usize) -> Option<String> {
        self.team.refusal_text(uav)
    }

    fn published_tube(&self) -> Option<(u32, &host_sim::scenario::SimTube)> {
        self.team.published_tube()
    }

    fn replan_stats(&self) -> Option<host_sim::mission::replan::ReplanStats> {
        self.team.replan_stats()
    }
}

/// Writes `text` as scenario `name` in a temporary folder of its own (`tag`), runs `host-sim run`
/// on it and asserts exit 2 without a panic, with every string of `must_contain` on stderr.
pub fn expect_exit_2(tag: &str, text: &str, name: &str, must_contain: &[&str]) {
    let dir = std::env::temp_dir().join(format!("vt-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = dir.join(name);
    std::fs::write(&path, text).expect("write scenario");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args(["run", path.to_str().expect("utf-8 path"), "--out"])
        .arg(dir.join("out"))
        .output()
        .expect("host-sim runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{name}: {err}");
    assert!(!err.contains("panicked"), "{name}: {err}");
    for m in must_contain {
        assert!(err.contains(m), "{name}: `{m}` not in: {err}");
    }
}

/// Whether the emulator `qemu` can run. When it cannot, a test prints why it is skipped
/// (`what` did not run) and passes vacuously, unless `VT_REQUIRE_QEMU=1` (set by
/// `scripts/test-all.sh`, hence in CI), which makes a missing emulator a failure.
pub fn qemu_present(qemu: &str, what: &str) -> bool {
    if host_sim::pil::qemu_available(qemu) {
        return true;
    }
    assert!(
        std::env::var_os("VT_REQUIRE_QEMU").is_none_or(|v| v != "1"),
        "{qemu} not found and VT_REQUIRE_QEMU=1: install it (apt-get install -y qemu-system-arm)"
    );
    eprintln!("SKIPPED: {qemu} not found (apt-get install -y qemu-system-arm); {what} did not run");
    false
}

/// The generated campaign's 1x mission of `seed` (`scenarios/campaigns/generated.toml`, the
/// real-aircraft world), checked to be the draw (team size, airframe) the test was written on.
pub fn generated(seed: u64, n_uavs: usize, airframe: &str) -> String {
    let base = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/campaigns/generated.toml");
    let c = host_sim::campaign::load(Some(&base)).expect("the generated campaign");
    let g = host_sim::scenario::generate::generate(c.tables.first().expect("a level"), seed).expect("the seed draws");
    assert_eq!((g.drawn.n_uavs, g.drawn.airframe.name), (n_uavs, airframe), "the draw this test was written on");
    g.text
}
