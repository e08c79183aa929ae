//! `[controller.shape]`: the formation shaped to the tube ahead (extension, issues 27 and 29;
//! `vt_dissipative::shape`, docs/design.md "A formation shaped to the tube").

use serde::Deserialize;

/// Settings of the tube-shaped formation; every field has a default.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShapeSpec {
    /// On: the rest lengths follow a stadium as narrow as the tube ahead needs (`VT_SHAPE`).
    /// Off: the take-off ring, the paper's controller.
    #[serde(default)]
    pub enabled: bool,
    /// Room kept between the nodes and the tube barrier's safety radius, m (`VT_SHAPE_MRG`).
    #[serde(default = "default_margin")]
    pub margin_m: f64,
    /// How far past the formation's front the tube's width is looked at, m (`VT_SHAPE_AHD`).
    #[serde(default = "default_ahead")]
    pub ahead_m: f64,
    /// The team keeps the tube together: each UAV's keeping term is the mean of every node's
    /// plus half its own (`VT_SHAPE_TEAM`; extension, docs/design.md "The tube keeps the team,
    /// not one node"). Off: each node its own, as the paper.
    #[serde(default = "default_team_keeping")]
    pub team_keeping: bool,
}

impl Default for ShapeSpec {
    fn default() -> Self {
        Self { enabled: false, margin_m: default_margin(), ahead_m: default_ahead(), team_keeping: default_team_keeping() }
    }
}

fn default_margin() -> f64 {
    f64::from(vt_dissipative::ShapeParams::default().margin_m)
}
fn default_team_keeping() -> bool {
    true
}
fn default_ahead() -> f64 {
    f64::from(vt_dissipative::ShapeParams::default().ahead_m)
}
