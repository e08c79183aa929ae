//! A miss on a run of cells four at a time: the Cortex-M4's DSP extension adds, saturates and
//! clamps four `i8` cells in three instructions ([`vt_fpu::i8x4_add_sat_max`]), where one cell
//! alone costs seven. Elsewhere the same arithmetic runs cell by cell; both give the same bits,
//! so the map is identical on the host and the MCU (PIL).

/// Adds `miss` to every cell of `run`, saturating at the `i8` range, and raises each to at least
/// `floor`: `max(sat(c + miss), floor)`.
pub(crate) fn miss_run(run: &mut [i8], miss: i8, floor: i8) {
    let (miss4, floor4) = (splat(miss), splat(floor));
    let mut words = run.chunks_exact_mut(4);
    for c in &mut words {
        if let Ok(b) = <&mut [i8; 4]>::try_from(c) {
            let w = u32::from_le_bytes(b.map(|x| x as u8));
            *b = miss_lanes(w, miss4, floor4).to_le_bytes().map(|x| x as i8);
        }
    }
    for c in words.into_remainder() {
        *c = miss_one(*c, miss, floor);
    }
}

/// `max(sat(c + miss), floor)` for one cell.
#[inline(always)]
pub(crate) fn miss_one(c: i8, miss: i8, floor: i8) -> i8 {
    let sum = c.saturating_add(miss);
    if sum < floor {
        floor
    } else {
        sum
    }
}

/// `v` in each byte lane of a word.
fn splat(v: i8) -> u32 {
    u32::from_le_bytes([v as u8; 4])
}

/// [`miss_one`] on the four byte lanes of `w` (little-endian), `miss4` and `floor4` splatted.
#[inline(always)]
fn miss_lanes(w: u32, miss4: u32, floor4: u32) -> u32 {
    vt_fpu::i8x4_add_sat_max(w, miss4, floor4)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_run_is_its_cells_one_by_one() {
        for (miss, floor) in [(-7i8, -32i8), (-14, -32), (-128, -128), (-1, -1), (-100, -20)] {
            for len in 0..11 {
                let mut run: Vec<i8> = (0..len).map(|k: i32| (k * 53 % 256 - 128) as i8).collect();
                let want: Vec<i8> = run.iter().map(|&c| miss_one(c, miss, floor)).collect();
                miss_run(&mut run, miss, floor);
                assert_eq!(run, want, "miss {miss} floor {floor} len {len}");
            }
        }
        // Every cell value, saturating at -128 and clamped.
        for c in i8::MIN..=i8::MAX {
            assert_eq!(miss_one(c, -14, -32), (i16::from(c) - 14).clamp(-128, 127).max(-32) as i8);
        }
    }
}
