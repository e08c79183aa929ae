//! What a run leaves behind for reports: the scene's geometry and the sampled time histories.
//! Filled by the runner, read by the CSV/JSON writers and the plots.

/// Horizontal geometry of the scene, world ENU metres.
#[derive(Debug, Clone, Default)]
pub struct SceneGeometry {
    /// Generator curve samples `gamma(s)`, m.
    pub centerline: Vec<[f64; 2]>,
    /// Left boundary `gamma + w_L n`, m.
    pub left_boundary: Vec<[f64; 2]>,
    /// Right boundary `gamma - w_R n`, m.
    pub right_boundary: Vec<[f64; 2]>,
    /// Obstacles (vertical cylinders): centre and radius, m.
    pub obstacles: Vec<Obstacle>,
    /// Plot extent `[x_min, x_max, y_min, y_max]`, m.
    pub bounds_m: [f64; 4],
    /// The map and corridor of a scenario whose tube was planned (`[tube] plan`), drawn in the
    /// top view; `None` for a hand-made tube.
    pub plan: Option<std::sync::Arc<PlanScene>>,
}

/// What the top view shows of a planned tube (issue 16): the map it was planned on and the
/// planner's result (corridor discs, bottleneck).
#[derive(Debug)]
pub struct PlanScene {
    /// The map (obstacle list or occupancy grid).
    pub map: crate::map::LoadedMap,
    /// The planned tube with its corridor.
    pub tube: vt_plan::PlannedTube,
}

/// A vertical cylindrical obstacle.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Obstacle {
    /// Centre, m.
    pub center_m: [f64; 2],
    /// Radius, m.
    pub radius_m: f64,
}

/// Time histories of one run, sampled at the record rate.
#[derive(Debug, Clone, Default)]
pub struct RunRecord {
    /// Scenario name.
    pub scenario: String,
    /// Controller name (`dissipative` or `baseline`).
    pub controller: String,
    /// Cable capacity `f_max`, N.
    pub f_max_n: f64,
    /// Load altitude reference, m.
    pub load_altitude_ref_m: f64,
    /// Sample times, s.
    pub time_s: Vec<f64>,
    /// UAV positions `[sample][uav]`, m.
    pub uav_pos_m: Vec<Vec<[f64; 3]>>,
    /// UAV velocities `[sample][uav]`, m/s.
    pub uav_vel_mps: Vec<Vec<[f64; 3]>>,
    /// Applied thrust magnitudes `[sample][uav]`, N.
    pub thrust_n: Vec<Vec<f64>>,
    /// Cable tensions `[sample][uav]`, N.
    pub tension_n: Vec<Vec<f64>>,
    /// Load position per sample, m.
    pub load_pos_m: Vec<[f64; 3]>,
    /// Load velocity per sample, m/s.
    pub load_vel_mps: Vec<[f64; 3]>,
    /// Minimum UAV-to-tube-boundary distance per sample, m.
    pub min_uav_boundary_m: Vec<f64>,
    /// Load-to-tube-boundary distance per sample, m.
    pub min_load_boundary_m: Vec<f64>,
    /// Minimum UAV-to-UAV distance per sample, m.
    pub min_uav_uav_m: Vec<f64>,
    // ---- issue 17 (replay, MCAP): every field below may be empty / zero (older backends).
    /// Controller mode `[sample][uav]`: [`MODE_TRANSPORT`] or [`MODE_HOLD`]; may be empty.
    pub uav_mode: Vec<Vec<u8>>,
    /// Timeline events (faults, hold entered / left), in time order; may be empty.
    pub events: Vec<RecordEvent>,
    /// Rated cable capacity the replay colours tensions against, N (0: use `f_max_n`).
    pub rated_n: f64,
    /// Virtual tray height above the load `h` (eq:2-4), m (0: tray not drawn).
    pub tray_height_m: f64,
    /// Velocity commands of the high-level controller `[sample][uav]`, m/s, world ENU; may be empty.
    pub vel_cmd_mps: Vec<Vec<[f64; 3]>>,
    /// CFO estimate of the cable force on each UAV `f_hat` `[sample][uav]`, N; may be empty.
    pub f_hat_n: Vec<Vec<[f64; 3]>>,
}

/// Controller mode of a UAV in [`RunRecord::uav_mode`]: flying the transport law.
pub const MODE_TRANSPORT: u8 = 0;
/// Controller mode of a UAV in [`RunRecord::uav_mode`]: hold (its own failsafe, or the team
/// failsafe's team hold; docs/design.md, "Team failsafe").
pub const MODE_HOLD: u8 = 1;

/// What happened at a [`RecordEvent`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum EventKind {
    /// The UAV's cable snapped (fault).
    Snap,
    /// The UAV stopped transmitting (fault).
    Silent,
    /// The UAV lost its thrust (fault).
    ThrustLoss,
    /// The UAV's own position feed to its companion stalled (fault, for its duration).
    OwnFeedStall,
    /// The UAV's team link died (fault).
    LinkDead,
    /// The UAV's controller entered hold.
    Hold,
    /// The UAV's controller left hold (back to transport).
    Resume,
    /// Ground start: the team's take-off began (the first UAV to enter a phase marks it).
    PhaseTakeoff,
    /// Ground start: the tension build-up began.
    PhaseTension,
    /// Ground start: the lift began.
    PhaseLift,
    /// Ground start: the climb began (the load left the ground).
    PhaseClimb,
    /// Ground start: the transport began.
    PhaseTransport,
    /// Ground start: the descent began.
    PhaseDescent,
    /// Ground start: the load is down, the cables slacken.
    PhaseSlack,
    /// Ground start: the team released the load.
    PhaseReleased,
}

impl EventKind {
    /// The event of a ground start's phase change.
    pub fn of_phase(p: vt_dissipative::Phase) -> Self {
        use vt_dissipative::Phase;
        match p {
            Phase::Takeoff => Self::PhaseTakeoff,
            Phase::Tension => Self::PhaseTension,
            Phase::Lift => Self::PhaseLift,
            Phase::Climb => Self::PhaseClimb,
            Phase::Transport => Self::PhaseTransport,
            Phase::Descent => Self::PhaseDescent,
            Phase::Slack => Self::PhaseSlack,
            Phase::Released => Self::PhaseReleased,
        }
    }
}

/// One event on the run's timeline.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct RecordEvent {
    /// Simulated time, s.
    pub time_s: f64,
    /// What happened.
    pub kind: EventKind,
    /// The UAV concerned (0-based).
    pub uav: usize,
}

impl From<crate::scenario::FaultKind> for EventKind {
    fn from(k: crate::scenario::FaultKind) -> Self {
        use crate::scenario::FaultKind;
        match k {
            FaultKind::CableSnap => Self::Snap,
            FaultKind::UavSilent => Self::Silent,
            FaultKind::ThrustLoss => Self::ThrustLoss,
            FaultKind::OwnFeedStall => Self::OwnFeedStall,
            FaultKind::LinkDead => Self::LinkDead,
        }
    }
}

impl RunRecord {
    /// The capacity tensions are coloured against, N: `rated_n` when set, else `f_max_n`.
    pub fn rated_capacity_n(&self) -> f64 {
        if self.rated_n > 0.0 { self.rated_n } else { self.f_max_n }
    }
}

/// The trajectory as CSV: one row per record sample (`trajectory.csv`; the format
/// [`crate::score`] reads).
pub fn trajectory_csv(r: &RunRecord) -> String {
    use std::fmt::Write as _;
    let n = r.uav_pos_m.first().map_or(0, Vec::len);
    let mut s = String::from("time_s");
    for i in 0..n {
        for c in ["x_m", "y_m", "z_m", "vx_mps", "vy_mps", "vz_mps", "thrust_n", "tension_n"] {
            let _ = write!(s, ",uav{i}_{c}");
        }
    }
    s.push_str(",load_x_m,load_y_m,load_z_m,load_vx_mps,load_vy_mps,load_vz_mps,min_uav_boundary_m,min_load_boundary_m,min_uav_uav_m\n");
    for k in 0..r.time_s.len() {
        let _ = write!(s, "{}", r.time_s[k]);
        for i in 0..n {
            let p = r.uav_pos_m[k][i];
            let v = r.uav_vel_mps[k][i];
            let _ = write!(s, ",{},{},{},{},{},{},{},{}", p[0], p[1], p[2], v[0], v[1], v[2], r.thrust_n[k][i], r.tension_n[k][i]);
        }
        let p = r.load_pos_m[k];
        let v = r.load_vel_mps[k];
        let _ = writeln!(
            s,
            ",{},{},{},{},{},{},{},{},{}",
            p[0], p[1], p[2], v[0], v[1], v[2], r.min_uav_boundary_m[k], r.min_load_boundary_m[k], r.min_uav_uav_m[k]
        );
    }
    s
}
