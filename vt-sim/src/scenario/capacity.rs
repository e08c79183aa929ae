//! `[controller.capacity]`: the capacity-aware formation (issue 15; `vt_dissipative::capacity`,
//! docs/design.md "Capacity-aware formation"). The declared load is `load.mass_kg`, the per-UAV
//! capacity `cables.rated_n`; the table holds the law's own settings.

use serde::Deserialize;

/// Settings of the capacity-aware formation; every field has a default.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CapacitySpec {
    /// The law is on (the formation adapts to the declared load; the observer is warm-started
    /// with the declared load's share). Off: the paper's controller as published.
    #[serde(default = "yes")]
    pub enabled: bool,
    /// Capacity margin the formation is chosen for: `C(lambda) >= (1 + margin) W`.
    #[serde(default = "default_margin")]
    pub margin: f64,
    /// Smallest UAV-UAV distance the adapted formation keeps, m (default: the mission's safety
    /// distance plus the controller's tube safety radius `r_safe_m`).
    #[serde(default)]
    pub separation_m: Option<f64>,
    /// Largest closing rate of the formation scale, 1/s (it opens at a quarter of it).
    #[serde(default = "default_rate")]
    pub rate_per_s: f64,
    /// Load sag where the overload response begins, m.
    #[serde(default = "default_sag_start")]
    pub sag_start_m: f64,
    /// Load sag where the overload response is complete, m.
    #[serde(default = "default_sag_full")]
    pub sag_full_m: f64,
}

impl Default for CapacitySpec {
    fn default() -> Self {
        Self {
            enabled: true,
            margin: default_margin(),
            separation_m: None,
            rate_per_s: default_rate(),
            sag_start_m: default_sag_start(),
            sag_full_m: default_sag_full(),
        }
    }
}

fn yes() -> bool {
    true
}
fn default_margin() -> f64 {
    f64::from(vt_dissipative::CapacityParams::default().margin)
}
fn default_rate() -> f64 {
    f64::from(vt_dissipative::CapacityParams::default().rate_per_s)
}
fn default_sag_start() -> f64 {
    f64::from(vt_dissipative::CapacityParams::default().sag_start_m)
}
fn default_sag_full() -> f64 {
    f64::from(vt_dissipative::CapacityParams::default().sag_full_m)
}
