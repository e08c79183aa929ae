//! Two command streams compared bit for bit (SIL twin against PIL or SITL).

use super::flight::{field_name, CommandRecord};
use serde::Serialize;

/// The first command that differs between SIL and PIL.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Difference {
    /// Plant step.
    pub step: u64,
    /// Simulated time, s.
    pub time_s: f64,
    /// UAV index.
    pub uav: usize,
    /// Field.
    pub field: String,
    /// SIL value.
    pub sil: f32,
    /// PIL value.
    pub pil: f32,
}

/// Compares two command streams.
pub fn compare(sil: &[CommandRecord], pil: &[CommandRecord], dt_s: f64) -> (usize, f64, bool, Option<Difference>) {
    let mut max_abs = 0.0f64;
    let mut first = None;
    let mut exact = sil.len() == pil.len();
    for (a, b) in sil.iter().zip(pil.iter()) {
        if a.step != b.step || a.uav != b.uav || a.kind != b.kind || a.values.len() != b.values.len() {
            exact = false;
            if first.is_none() {
                first = Some(Difference { step: a.step, time_s: a.step as f64 * dt_s, uav: a.uav, field: "sequence".into(), sil: f32::NAN, pil: f32::NAN });
            }
            break;
        }
        for (k, (x, y)) in a.values.iter().zip(b.values.iter()).enumerate() {
            if x.to_bits() != y.to_bits() {
                exact = false;
                let d = f64::from(*x) - f64::from(*y);
                max_abs = max_abs.max(if d.is_nan() { f64::INFINITY } else { d.abs() });
                if first.is_none() {
                    first = Some(Difference { step: a.step, time_s: a.step as f64 * dt_s, uav: a.uav, field: field_name(a.kind, k).into(), sil: *x, pil: *y });
                }
            }
        }
    }
    (sil.len().min(pil.len()), max_abs, exact, first)
}
