//! Why a companion holds: the bits of `HEARTBEAT.custom_mode >> 8` (docs/protocol.md).

/// Why the companion holds (bit set, reported in telemetry).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct HoldReasons(pub u8);

impl HoldReasons {
    /// Own state stale or missing.
    pub const OWN_STALE: u8 = 1 << 0;
    /// Load state stale or missing.
    pub const LOAD_STALE: u8 = 1 << 1;
    /// A neighbour's position stale or missing.
    pub const NEIGHBOUR_STALE: u8 = 1 << 2;
    /// The high-level controller flagged invalid input.
    pub const INVALID_INPUT: u8 = 1 << 3;
    /// A command was non-finite.
    pub const NONFINITE: u8 = 1 << 4;
    /// The operator asked for a hold (`MAV_CMD_DO_PAUSE_CONTINUE` with `param1 = 0`, or the
    /// Linux companion's Ctrl-C); cleared by a continue.
    pub const OPERATOR: u8 = 1 << 5;
    /// Ground start: this UAV refused its arming or abandoned its lift (its cable slackens);
    /// the team holds, so its lift is abandoned too (`vt_dissipative::phases::LIFT_HOLD_ABORT_S`).
    pub const REFUSED: u8 = 1 << 6;
    /// Issue 28: the planner found no route to the goal on the map as seen; the team holds in
    /// place (the mission fails with this reason, never by a collision).
    pub const NO_ROUTE: u8 = 1 << 7;

    /// True when no reason is set.
    pub fn is_clear(self) -> bool {
        self.0 == 0
    }
}
