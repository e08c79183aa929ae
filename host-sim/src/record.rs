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
}
