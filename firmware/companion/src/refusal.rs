//! Why `MAV_CMD_MISSION_START` was refused, for telemetry (docs/protocol.md): a code for
//! `HEARTBEAT.custom_mode` and `STATUSTEXT` lines with the numbers.
//!
//! The text is built in a fixed 50-byte buffer (`STATUSTEXT.text`) with a small fixed-point
//! formatter: no allocation, and no `core::fmt` float machinery in the firmware's flash.

use crate::flight::StartError;
use vt_dissipative::wind::{WindError, WindLimit};
use vt_dissipative::{CalibrationError, ControlError, FeasibilityError};

/// Length of `STATUSTEXT.text`, bytes.
pub const STATUS_TEXT_LEN: usize = 50;

/// One `STATUSTEXT` line: ASCII, truncated at [`STATUS_TEXT_LEN`], NUL-padded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Line {
    buf: [u8; STATUS_TEXT_LEN],
    len: usize,
}

impl Default for Line {
    fn default() -> Self {
        Self::new()
    }
}

impl Line {
    /// An empty line.
    pub const fn new() -> Self {
        Self { buf: [0; STATUS_TEXT_LEN], len: 0 }
    }

    /// Appends `s` (what does not fit is dropped). Never inlined: it is called from many
    /// places that run once, and flash matters more than speed there.
    #[inline(never)]
    pub fn push(&mut self, s: &str) -> &mut Self {
        for &b in s.as_bytes() {
            if let Some(slot) = self.buf.get_mut(self.len) {
                *slot = b;
                self.len += 1;
            }
        }
        self
    }

    /// Appends an unsigned integer (32-bit: the MCU divides those in hardware).
    #[inline(never)]
    pub fn push_u32(&mut self, mut v: u32) -> &mut Self {
        let mut digits = [0u8; 10];
        let mut k = digits.len();
        loop {
            k -= 1;
            if let Some(d) = digits.get_mut(k) {
                *d = b'0' + (v % 10) as u8;
            }
            v /= 10;
            if v == 0 || k == 0 {
                break;
            }
        }
        for &d in digits.get(k..).unwrap_or(&[]) {
            if let Some(slot) = self.buf.get_mut(self.len) {
                *slot = d;
                self.len += 1;
            }
        }
        self
    }

    /// Appends an index or count (saturated at `u32::MAX`).
    pub fn push_usize(&mut self, v: usize) -> &mut Self {
        self.push_u32(u32::try_from(v).unwrap_or(u32::MAX))
    }

    /// Appends `x` rounded to `decimals` (at most 3) decimals; `nan`/`inf` for non-finite,
    /// `>1e6` beyond a million.
    pub fn push_fixed(&mut self, x: f32, decimals: u32) -> &mut Self {
        if !x.is_finite() {
            return self.push(if x.is_nan() { "nan" } else if x > 0.0 { "inf" } else { "-inf" });
        }
        if x.abs() >= 1.0e6 {
            return self.push(if x > 0.0 { ">1e6" } else { "<-1e6" });
        }
        let d = decimals.min(3);
        let scale = 10u32.pow(d);
        // f32 keeps 7 significant digits: plenty for telemetry; |x| scale < 1e9 fits a u32.
        let scaled = libm::roundf(x.abs() * scale as f32) as u32;
        if x < 0.0 && scaled > 0 {
            self.push("-");
        }
        self.push_u32(scaled / scale);
        if d > 0 {
            self.push(".");
            let frac = scaled % scale;
            let mut p = scale / 10;
            while p > 0 {
                self.push_u32((frac / p) % 10);
                p /= 10;
            }
        }
        self
    }

    /// The text so far.
    pub fn as_str(&self) -> &str {
        core::str::from_utf8(self.buf.get(..self.len).unwrap_or(&[])).unwrap_or("")
    }

    /// The NUL-padded buffer for `STATUSTEXT.text`.
    pub fn bytes(&self) -> [u8; STATUS_TEXT_LEN] {
        self.buf
    }
}

/// The refusal in full (the crates' own messages with every number), for a log or a host; the
/// link carries [`StartError::lines`].
impl core::fmt::Display for StartError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::NoTube => f.write_str("no valid tube uploaded"),
            Self::BadTeam => f.write_str("VT_ID >= VT_N_UAVS, or VT_LL_HZ not a multiple of VT_HL_HZ"),
            Self::StaleData => f.write_str("own, load or a neighbour's state missing or stale"),
            Self::Controller(e) => write!(f, "controller parameters: {e}"),
            Self::VelocityLoop(e) => write!(f, "velocity loop parameters: {e}"),
            Self::Calibration(e) => write!(f, "take-off calibration: {e}"),
            Self::Infeasible(e) => write!(f, "pre-flight check: {e}"),
            Self::Wind(e) => write!(f, "pre-flight wind check: {e}"),
            Self::LiftFailed => f.write_str("lift abandoned: the load did not leave the ground (overload or snagged load)"),
            Self::NoMap => f.write_str("PR_MAP = 1 (unknown map), but this build has no onboard map or the world PR_X0..PR_Y1 does not fit it at PR_CELL"),
            Self::Station { drift_m } => {
                // The fixed-point formatter: no `core::fmt` float machinery in the flash.
                let mut d = Line::new();
                d.push_fixed(*drift_m, 2);
                write!(f, "take-off abandoned: drifted {} m from the own place (a wind beyond what the UAV holds); landing", d.as_str())
            }
        }
    }
}

/// How the headline of a refusal's `STATUSTEXT` begins ([`StartError::lines`]).
pub const REFUSAL_HEAD: &str = "start refused: ";

impl StartError {
    /// The refusal code reported in `HEARTBEAT.custom_mode` bits 16..23 (0: none).
    pub fn code(&self) -> u8 {
        match self {
            Self::NoTube => 1,
            Self::BadTeam => 2,
            Self::StaleData => 3,
            Self::Controller(_) => 4,
            Self::VelocityLoop(_) => 5,
            Self::Calibration(_) => 6,
            Self::Infeasible(_) => 7,
            Self::Wind(_) => 8,
            Self::LiftFailed => 9,
            Self::Station { .. } => 10,
            Self::NoMap => 11,
        }
    }

    /// The `STATUSTEXT` lines: a headline (beginning [`REFUSAL_HEAD`]), and the numbers when
    /// there are any.
    #[inline(never)]
    pub fn lines(&self) -> (Line, Option<Line>) {
        let mut head = Line::new();
        head.push(REFUSAL_HEAD);
        let mut detail = Line::new();
        let has_detail = match self {
            Self::NoTube => {
                head.push("no tube");
                false
            }
            Self::BadTeam => {
                head.push("VT_ID, VT_N_UAVS or rates");
                false
            }
            Self::StaleData => {
                head.push("stale own, load or team data");
                false
            }
            Self::Controller(e) => {
                head.push("controller parameters");
                control_detail(e, &mut detail)
            }
            Self::VelocityLoop(_) => {
                head.push("velocity loop parameters");
                false
            }
            Self::Calibration(e) => {
                head.push("cable calibration");
                calibration_detail(e, &mut detail);
                true
            }
            Self::Infeasible(e) => {
                head.push("team cannot lift the load");
                feasibility_detail(e, &mut detail);
                true
            }
            Self::Wind(e) => {
                head.push("wind above the team's capacity");
                wind_detail(e, &mut detail);
                true
            }
            Self::LiftFailed => {
                head.push("load did not leave the ground");
                false
            }
            Self::NoMap => {
                head.push("no onboard map");
                detail.push(if cfg!(feature = "perception") { "PR_X0..PR_Y1 too large at PR_CELL" } else { "PR_MAP 1: build without perception" });
                true
            }
            Self::Station { drift_m } => {
                head.push("cannot hold station, landing");
                detail.push("drifted ").push_fixed(*drift_m, 2).push("m > ").push_fixed(vt_dissipative::landing::STATION_DRIFT_ABORT_M, 2).push("m");
                true
            }
        };
        (head, has_detail.then_some(detail))
    }
}

fn control_detail(e: &ControlError, l: &mut Line) -> bool {
    match e {
        ControlError::InvalidParameter(name) => {
            l.push(name);
            true
        }
        ControlError::BadTakeoff { index } => {
            l.push("take-off of UAV ").push_usize(*index);
            true
        }
        _ => false,
    }
}

fn calibration_detail(e: &CalibrationError, l: &mut Line) {
    match *e {
        CalibrationError::InvalidParameter(name) => {
            l.push(name);
        }
        CalibrationError::IdOutOfRange { id, n_uavs } => {
            l.push("VT_ID ").push_usize(id).push(" >= team ").push_usize(n_uavs);
        }
        CalibrationError::NonFiniteLoad => {
            l.push("load position non-finite");
        }
        CalibrationError::NonFiniteUav { index } => {
            l.push("UAV ").push_usize(index).push(" position non-finite");
        }
        CalibrationError::NotAboveLoad { index } => {
            l.push("UAV ").push_usize(index).push(" not above the load");
        }
        CalibrationError::TooFlat { index, cos_lean } => {
            l.push("UAV ").push_usize(index).push(" lean cos ").push_fixed(cos_lean, 3).push(" too flat");
        }
        CalibrationError::StretchExceedsDistance { stretch_m, distance_m } => {
            l.push("stretch ").push_fixed(stretch_m, 3).push("m >= distance ").push_fixed(distance_m, 3).push("m");
        }
        CalibrationError::LengthOutOfRange { length_m, min_m, max_m } => {
            l.push("cable ").push_fixed(length_m, 2).push("m not in (").push_fixed(min_m, 2).push(", ").push_fixed(max_m, 2).push("]m");
        }
    }
}

fn wind_detail(e: &WindError, l: &mut Line) {
    match *e {
        WindError::InvalidParameter(name) => {
            l.push(name);
        }
        WindError::TooStrong { wind_mps, capacity_mps, limit } => {
            l.push("wind ").push_fixed(wind_mps, 1).push("m/s > cap ").push_fixed(capacity_mps, 1).push("m/s (").push(match limit {
                WindLimit::Tilt => "tilt",
                WindLimit::Thrust => "thrust",
                WindLimit::Cable => "cable",
            });
            l.push(")");
        }
    }
}

fn feasibility_detail(e: &FeasibilityError, l: &mut Line) {
    match *e {
        FeasibilityError::InvalidParameter(name) => {
            l.push(name);
        }
        FeasibilityError::Infeasible { needed_n, available_n, margin, min_margin } => {
            l.push("need ")
                .push_fixed(needed_n, 1)
                .push("N have ")
                .push_fixed(available_n, 1)
                .push("N margin ")
                .push_fixed(100.0 * margin, 1)
                .push("% min ")
                .push_fixed(100.0 * min_margin, 1)
                .push("%");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fixed_point_by_hand() {
        let f = |x: f32, d: u32| {
            let mut l = Line::new();
            l.push_fixed(x, d);
            l.as_str().to_string()
        };
        assert_eq!(f(194.238, 1), "194.2");
        assert_eq!(f(-1.3499, 1), "-1.3");
        assert_eq!(f(-0.04, 1), "0.0");
        assert_eq!(f(2.0, 1), "2.0");
        assert_eq!(f(0.4999, 3), "0.500");
        assert_eq!(f(1765.8, 0), "1766");
        assert_eq!(f(f32::NAN, 1), "nan");
        assert_eq!(f(-f32::INFINITY, 1), "-inf");
        assert_eq!(f(3e6, 1), ">1e6");
    }

    #[test]
    fn long_text_is_truncated_at_50_bytes() {
        let mut l = Line::new();
        l.push("0123456789".repeat(6).as_str());
        assert_eq!(l.as_str().len(), STATUS_TEXT_LEN);
        assert_eq!(l.bytes()[49], b'9');
    }

    #[test]
    fn infeasible_text_carries_the_numbers() {
        let e = StartError::Infeasible(FeasibilityError::Infeasible { needed_n: 1765.8, available_n: 1916.4, margin: -0.0787, min_margin: 0.02 });
        let (head, detail) = e.lines();
        assert_eq!(head.as_str(), "start refused: team cannot lift the load");
        let detail = detail.unwrap();
        assert_eq!(detail.as_str(), "need 1765.8N have 1916.4N margin -7.9% min 2.0%");
        assert!(detail.as_str().len() < STATUS_TEXT_LEN, "room to spare");
        assert_eq!(e.code(), 7);
    }

    #[test]
    fn calibration_texts() {
        let t = |e: CalibrationError| StartError::Calibration(e).lines().1.unwrap().as_str().to_string();
        assert_eq!(t(CalibrationError::NotAboveLoad { index: 3 }), "UAV 3 not above the load");
        assert_eq!(t(CalibrationError::TooFlat { index: 1, cos_lean: 0.42 }), "UAV 1 lean cos 0.420 too flat");
        assert_eq!(t(CalibrationError::LengthOutOfRange { length_m: 12.345, min_m: 1.0, max_m: 10.0 }), "cable 12.35m not in (1.00, 10.00]m");
        assert_eq!(StartError::Calibration(CalibrationError::NonFiniteLoad).code(), 6);
    }
}
