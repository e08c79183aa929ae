//! The tube's waypoints over the MAVLink mission protocol (upload direction).
//!
//! `MISSION_COUNT` opens an upload of `count` items; the companion asks for each with
//! `MISSION_REQUEST_INT` and the sender answers `MISSION_ITEM_INT`:
//! `command = MAV_CMD_NAV_WAYPOINT`, `frame = MAV_FRAME_LOCAL_NED`, `x` = north and `y` = east in
//! units of 0.1 mm (`m * 1e4`, MAVLink's local-frame encoding), `param1` = left half-width and
//! `param2` = right half-width, m (left/right of the direction of travel; a project convention,
//! documented in `docs/protocol.md`). `z` is ignored (altitudes come from the load reference).
//! The last item is answered with `MISSION_ACK`: `MAV_MISSION_ACCEPTED` once the tube has been
//! built and validated (`vt_tube::Tube::from_waypoints`), else an error code.
//!
//! The metre value is `x as f32 / 1e4` (a correctly rounded division), which equals the `f32`
//! nearest to the decimal value for any waypoint given with at most four decimals, so the tube
//! matches the one host-sim builds from the scenario's numbers.

use heapless::Vec;
use vt_tube::Waypoint;

use crate::MAX_WAYPOINTS;

/// Local-frame coordinate scale of `MISSION_ITEM_INT` (units per metre).
pub const LOCAL_SCALE_PER_M: f32 = 1.0e4;

/// `m` (m) in the mission protocol's units of 0.1 mm (`MISSION_ITEM_INT.x`, `.y`): the
/// nearest count (rounded in `f64`, as a ground station does), `None` for a non-finite `m` or
/// one beyond the `i32` range.
pub fn wire_units(m: f32) -> Option<i32> {
    let x = libm::round(f64::from(m) * 1e4);
    (x.is_finite() && libm::fabs(x) <= f64::from(i32::MAX)).then_some(x as i32)
}

/// `m` (m) on the mission protocol's 0.1 mm grid, as a receiver rebuilds it from
/// [`wire_units`] (`x as f32 / 1e4`); unchanged when it has no count.
pub fn on_wire_grid_m(m: f32) -> f32 {
    wire_units(m).map_or(m, |x| x as f32 / LOCAL_SCALE_PER_M)
}

/// What to answer after an upload message.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum UploadReply {
    /// Ask for item `seq` (`MISSION_REQUEST_INT`).
    Request(u16),
    /// Upload finished: build the tube, then `MISSION_ACK`.
    Complete,
    /// Refuse with this `MAV_MISSION_RESULT`.
    Refuse(MissionResult),
    /// Nothing (not uploading: a stray item).
    Nothing,
}

/// The subset of `MAV_MISSION_RESULT` the companion answers with.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum MissionResult {
    /// `MAV_MISSION_ERROR`.
    Error,
    /// `MAV_MISSION_UNSUPPORTED_FRAME`.
    UnsupportedFrame,
    /// `MAV_MISSION_UNSUPPORTED`.
    Unsupported,
    /// `MAV_MISSION_NO_SPACE`.
    NoSpace,
    /// `MAV_MISSION_INVALID` (e.g. the tube was rejected).
    Invalid,
    /// `MAV_MISSION_INVALID_PARAM1` (a half-width).
    InvalidParam1,
    /// `MAV_MISSION_INVALID_SEQUENCE`.
    InvalidSequence,
    /// `MAV_MISSION_DENIED` (mission running).
    Denied,
}

/// One received item, already decoded from the wire.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Item {
    /// Sequence number.
    pub seq: u16,
    /// `MAV_FRAME` value.
    pub frame: u8,
    /// `MAV_CMD` value.
    pub command: u16,
    /// North, 1e-4 m.
    pub x: i32,
    /// East, 1e-4 m.
    pub y: i32,
    /// Left half-width, m.
    pub param1: f32,
    /// Right half-width, m.
    pub param2: f32,
}

/// `MAV_FRAME_LOCAL_NED`.
const FRAME_LOCAL_NED: u8 = 1;
/// `MAV_CMD_NAV_WAYPOINT`.
const CMD_NAV_WAYPOINT: u16 = 16;

impl Item {
    /// Waypoint `seq` of a tube as a ground station sends it: `MAV_CMD_NAV_WAYPOINT` in
    /// `MAV_FRAME_LOCAL_NED`, `x` north and `y` east in 1e-4 m, the half-widths in m.
    pub const fn tube_waypoint(seq: u16, x: i32, y: i32, w_left_m: f32, w_right_m: f32) -> Self {
        Self { seq, frame: FRAME_LOCAL_NED, command: CMD_NAV_WAYPOINT, x, y, param1: w_left_m, param2: w_right_m }
    }

    /// Waypoint `w` (world ENU, m) as item `seq`: north and east on the 0.1 mm grid
    /// ([`wire_units`]); `None` when a coordinate has no count.
    pub fn of_waypoint(seq: u16, w: &Waypoint) -> Option<Self> {
        Some(Self::tube_waypoint(seq, wire_units(w.pos_m.y)?, wire_units(w.pos_m.x)?, w.w_left_m, w.w_right_m))
    }
}

/// Upload state.
#[derive(Debug, Clone, Default)]
pub struct MissionUpload {
    expected: u16,
    waypoints: Vec<Waypoint, MAX_WAYPOINTS>,
    active: bool,
}

impl MissionUpload {
    /// No upload in progress.
    pub const fn new() -> Self {
        Self { expected: 0, waypoints: Vec::new(), active: false }
    }

    /// `MISSION_COUNT`: start an upload of `count` items.
    pub fn begin(&mut self, count: u16) -> UploadReply {
        self.waypoints.clear();
        self.active = false;
        if count < 2 {
            return UploadReply::Refuse(MissionResult::Invalid);
        }
        if usize::from(count) > MAX_WAYPOINTS {
            return UploadReply::Refuse(MissionResult::NoSpace);
        }
        self.expected = count;
        self.active = true;
        UploadReply::Request(0)
    }

    /// `MISSION_ITEM_INT`.
    pub fn item(&mut self, it: &Item) -> UploadReply {
        if !self.active {
            return UploadReply::Nothing;
        }
        let next = self.waypoints.len() as u16;
        if it.seq != next {
            // A repeated or early item: ask again for the one we need.
            return UploadReply::Request(next);
        }
        let mut refuse = |r| {
            self.active = false;
            UploadReply::Refuse(r)
        };
        if it.frame != FRAME_LOCAL_NED {
            return refuse(MissionResult::UnsupportedFrame);
        }
        if it.command != CMD_NAV_WAYPOINT {
            return refuse(MissionResult::Unsupported);
        }
        let width_ok = |w: f32| w.is_finite() && w > 0.0;
        if !(width_ok(it.param1) && width_ok(it.param2)) {
            return refuse(MissionResult::InvalidParam1);
        }
        let east_m = it.y as f32 / LOCAL_SCALE_PER_M;
        let north_m = it.x as f32 / LOCAL_SCALE_PER_M;
        if self.waypoints.push(Waypoint::new(east_m, north_m, it.param1, it.param2)).is_err() {
            return refuse(MissionResult::NoSpace);
        }
        if self.waypoints.len() == usize::from(self.expected) {
            self.active = false;
            UploadReply::Complete
        } else {
            UploadReply::Request(next + 1)
        }
    }

    /// The waypoints of the last complete upload (world ENU).
    pub fn waypoints(&self) -> &[Waypoint] {
        &self.waypoints
    }

    /// Forgets everything (`MISSION_CLEAR_ALL`).
    pub fn clear(&mut self) {
        *self = Self::new();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn item(seq: u16, x: i32, y: i32) -> Item {
        Item { seq, frame: FRAME_LOCAL_NED, command: CMD_NAV_WAYPOINT, x, y, param1: 3.5, param2: 1.8 }
    }

    #[test]
    fn upload_in_order() {
        let mut m = MissionUpload::new();
        assert_eq!(m.begin(2), UploadReply::Request(0));
        assert_eq!(m.item(&item(0, 0, 0)), UploadReply::Request(1));
        assert_eq!(m.item(&item(1, 10_000, 80_000)), UploadReply::Complete);
        assert_eq!(m.waypoints()[1], Waypoint::new(8.0, 1.0, 3.5, 1.8));
    }

    #[test]
    fn out_of_order_item_is_requested_again() {
        let mut m = MissionUpload::new();
        m.begin(3);
        assert_eq!(m.item(&item(1, 0, 0)), UploadReply::Request(0));
    }

    #[test]
    fn decimal_coordinates_match_the_f32_literal() {
        for v in [12.3_f64, 16.2, -4.0001, 21.0, 0.1, 7.77] {
            let wire = (v * 1e4).round() as i32;
            assert_eq!(wire as f32 / LOCAL_SCALE_PER_M, v as f32, "{v}");
        }
    }

    #[test]
    fn bad_width_and_frame_are_refused() {
        let mut m = MissionUpload::new();
        m.begin(2);
        let mut it = item(0, 0, 0);
        it.param2 = f32::NAN;
        assert_eq!(m.item(&it), UploadReply::Refuse(MissionResult::InvalidParam1));
        m.begin(2);
        it = item(0, 0, 0);
        it.frame = 0;
        assert_eq!(m.item(&it), UploadReply::Refuse(MissionResult::UnsupportedFrame));
        assert_eq!(m.begin(1), UploadReply::Refuse(MissionResult::Invalid));
        assert_eq!(m.begin(65), UploadReply::Refuse(MissionResult::NoSpace));
    }
}
