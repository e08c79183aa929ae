//! Health flags reported with every command.

/// What happened while computing a command. All-false means nominal.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Status {
    /// Own or load state was non-finite: the command fell back to zero horizontal velocity
    /// (hold) and the altitude law alone.
    pub invalid_input: bool,
    /// The UAV was at or below `min_height_above_load_m`: the node projection used that floor.
    pub projection_floored: bool,
    /// Two nodes coincided; a deterministic separation direction was used.
    pub coincident_nodes: bool,
    /// Neighbours missing, stale or non-finite (dropped from the spring set).
    pub neighbours_dropped: u8,
    /// The own node was outside the tube (`d_t <= 0`).
    pub outside_tube: bool,
    /// The synthesised command was non-finite and was replaced by hold.
    pub nonfinite_command: bool,
    /// The load sank below its reference by more than the capacity law's `sag_start_m`: the
    /// overload response (cables standing up, progress giving way) is active (capacity.rs).
    pub overload: bool,
}

impl Status {
    /// True when no flag is raised.
    pub fn is_nominal(&self) -> bool {
        *self == Self::default()
    }
}
