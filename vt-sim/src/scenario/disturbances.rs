//! `[disturbances]`: sensor noise, latency, wind, turbulence and model uncertainty (docs/scenario.md,
//! docs/robustness.md).

use serde::Deserialize;

/// How long a wind with `wind_onset_s` takes to build up, s.
pub const WIND_ONSET_RAMP_S: f64 = 5.0;

/// Sensor noise, latency, wind and model uncertainty. Zero means off.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DisturbanceSpec {
    /// Std. dev. of position noise on own, load and neighbour measurements, m.
    #[serde(default)]
    pub position_noise_m: f64,
    /// Std. dev. of velocity noise on own and load measurements, m/s.
    #[serde(default)]
    pub velocity_noise_mps: f64,
    /// Latency of own and load measurements, s (rounded to low-level periods).
    #[serde(default)]
    pub latency_s: f64,
    /// Extra random link delay per message, uniform in [0, jitter], s.
    #[serde(default)]
    pub link_jitter_s: f64,
    /// Mean wind, m/s (ENU).
    #[serde(default)]
    pub wind_mean_mps: [f64; 3],
    /// Std. dev. of the gust (first-order filtered noise) per horizontal axis, m/s.
    #[serde(default)]
    pub gust_std_mps: f64,
    /// Gust correlation time, s.
    #[serde(default = "default_gust_tau")]
    pub gust_tau_s: f64,
    /// When the wind (mean and gusts) sets in, s of mission time; it builds up linearly over
    /// [`WIND_ONSET_RAMP_S`] (a gust front; absent: blowing from the start).
    #[serde(default)]
    pub wind_onset_s: Option<f64>,
    /// Roughness length of the ground, m: below 20 ft the wind (mean and gusts) falls off along
    /// MIL-F-8785C's log law to nothing at this height ([`crate::disturbance::shear_factor`]);
    /// 0 blows the same wind down to the ground.
    #[serde(default = "default_roughness")]
    pub surface_roughness_m: f64,
    /// Drag area C_d A of each UAV, m^2.
    #[serde(default = "default_uav_drag")]
    pub uav_drag_area_m2: f64,
    /// Drag area C_d A of the load, m^2.
    #[serde(default = "default_load_drag")]
    pub load_drag_area_m2: f64,
    /// Relative cable length error, uniform in +-this (plant only; controllers use nominal).
    #[serde(default)]
    pub cable_length_error: f64,
    /// Relative cable stiffness error, uniform in +-this.
    #[serde(default)]
    pub cable_stiffness_error: f64,
    /// Relative UAV mass error, uniform in +-this.
    #[serde(default)]
    pub uav_mass_error: f64,
    /// Relative load mass error, uniform in +-this.
    #[serde(default)]
    pub load_mass_error: f64,
    /// Dryden turbulence (MIL-F-8785C low altitude) per UAV and for the load: 0 off, 1 light
    /// (15 kt at 20 ft), 2 moderate (30 kt); times `intensity` ([`crate::turbulence`]; issue 27).
    #[serde(default)]
    pub turbulence: f64,
    /// Relative error of each UAV's maximum thrust, uniform in +-this: the plant's true maximum
    /// differs from `uavs.thrust_max_n`, which the firmware believes (`VL_T_MAX`; issue 27).
    #[serde(default)]
    pub thrust_scale_error: f64,
    /// Multiplies every noise, wind and error magnitude above (campaign levels).
    #[serde(default = "super::one")]
    pub intensity: f64,
}

impl Default for DisturbanceSpec {
    fn default() -> Self {
        Self {
            position_noise_m: 0.0,
            velocity_noise_mps: 0.0,
            latency_s: 0.0,
            link_jitter_s: 0.0,
            wind_mean_mps: [0.0; 3],
            gust_std_mps: 0.0,
            gust_tau_s: default_gust_tau(),
            wind_onset_s: None,
            surface_roughness_m: default_roughness(),
            uav_drag_area_m2: default_uav_drag(),
            load_drag_area_m2: default_load_drag(),
            cable_length_error: 0.0,
            cable_stiffness_error: 0.0,
            uav_mass_error: 0.0,
            load_mass_error: 0.0,
            thrust_scale_error: 0.0,
            turbulence: 0.0,
            intensity: 1.0,
        }
    }
}

fn default_gust_tau() -> f64 {
    2.0
}
/// MIL-F-8785C's roughness length for the terminal flight phases (Category C), 0.15 ft:
/// short grass (WMO open terrain is 0.03 m).
fn default_roughness() -> f64 {
    0.15 * 0.3048
}
fn default_uav_drag() -> f64 {
    0.05
}
fn default_load_drag() -> f64 {
    0.3
}
