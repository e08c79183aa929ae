//! Firmware figures: flash and static RAM of each board image (built here, sizes read from the
//! ELF section headers), and the MCU measurements the firmware tooling provides (instruction
//! counts per UAV step and stack peak, measured under QEMU) through a hook command.
//!
//! # The hook
//! `firmware/bench.sh` (or the command given with `--mcu-cmd`), run from the repository root,
//! prints one JSON object on its last stdout line starting with `{`. Keys read (all optional):
//! - `mcu_instructions_per_uav_step`: `{"3": u, "10": u, "30": u}` (high level + low level),
//! - `mcu_instructions_high_level`: same shape; `mcu_instructions_low_level`: a number,
//! - `firmware_stack_peak_bytes`: `{"qemu": u, "stm32f405": u}`,
//! - `mcu_replan_instructions`, `mcu_map_update_instructions` (worst scan),
//!   `mcu_map_update_instructions_mean`, `mcu_map_fold_synthetic_worst_instructions`,
//!   `perception_state_bytes`, `perception_stack_bytes`: issue 28's perception bench,
//! - `firmware_flash_bytes`, `firmware_static_ram_bytes`: same shape; they replace the ELF
//!   figures measured here.

use std::fs;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use serde_json::{Map, Value};

use crate::Paths;

/// Boards the firmware builds for (cargo features of `firmware/`).
pub const BOARDS: [&str; 2] = ["qemu", "stm32f405"];
/// ELF section flag: writable.
const SHF_WRITE: u32 = 0x1;
/// ELF section flag: occupies memory at run time.
const SHF_ALLOC: u32 = 0x2;
/// ELF section type: no file data (`.bss`).
const SHT_NOBITS: u32 = 8;
/// Size of an ELF32 section header, bytes.
const SHDR_SIZE: usize = 40;
/// Longest the hook command may run.
const HOOK_TIMEOUT: Duration = Duration::from_secs(600);

/// Memory of one linked image, bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ImageSize {
    /// Everything stored in flash: vector table, code, read-only data, `.data` initialisers.
    pub flash_bytes: u64,
    /// Statically allocated RAM: `.data`, `.bss`, `.uninit` (the stack is not included).
    pub static_ram_bytes: u64,
}

/// Reads flash and static RAM from the section headers of a 32-bit little-endian ELF.
///
/// # Errors
/// Not a 32-bit little-endian ELF, or truncated.
pub fn elf_size(bytes: &[u8]) -> Result<ImageSize, String> {
    let u16_at = |o: usize| bytes.get(o..o + 2).and_then(|b| b.try_into().ok()).map(u16::from_le_bytes);
    let u32_at = |o: usize| bytes.get(o..o + 4).and_then(|b| b.try_into().ok()).map(u32::from_le_bytes);
    if bytes.get(0..6) != Some(&[0x7f, b'E', b'L', b'F', 1, 1][..]) {
        return Err("not a 32-bit little-endian ELF".into());
    }
    let truncated = || "truncated ELF".to_string();
    let shoff = u32_at(0x20).ok_or_else(truncated)? as usize;
    let shentsize = usize::from(u16_at(0x2E).ok_or_else(truncated)?);
    let shnum = usize::from(u16_at(0x30).ok_or_else(truncated)?);
    if shentsize < SHDR_SIZE {
        return Err(format!("unexpected section header size {shentsize}"));
    }
    let mut size = ImageSize { flash_bytes: 0, static_ram_bytes: 0 };
    for i in 0..shnum {
        let h = shoff + i * shentsize;
        let (sh_type, flags, len) = (
            u32_at(h + 4).ok_or_else(truncated)?,
            u32_at(h + 8).ok_or_else(truncated)?,
            u64::from(u32_at(h + 20).ok_or_else(truncated)?),
        );
        if flags & SHF_ALLOC == 0 {
            continue;
        }
        if sh_type != SHT_NOBITS {
            size.flash_bytes += len;
        }
        if flags & SHF_WRITE != 0 {
            size.static_ram_bytes += len;
        }
    }
    Ok(size)
}

/// Builds the firmware for `board` (release, the firmware's own target directory) and measures
/// its image.
///
/// # Errors
/// The build failed (the last lines of its output) or the ELF is unreadable.
pub fn build_and_measure(paths: &Paths, board: &str) -> Result<ImageSize, String> {
    let fw = paths.root.join("firmware");
    let target_dir = fw.join("target");
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(cargo)
        .current_dir(&fw)
        .args(["build", "--release", "--features", board])
        .env("CARGO_TARGET_DIR", &target_dir)
        .env_remove("RUSTFLAGS")
        .env_remove("CARGO_ENCODED_RUSTFLAGS")
        .env_remove("CARGO_BUILD_TARGET")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .output()
        .map_err(|e| format!("cannot start cargo build: {e}"))?;
    if !out.status.success() {
        let text = String::from_utf8_lossy(&out.stderr);
        let tail: Vec<&str> = text.lines().filter(|l| l.starts_with("error")).take(3).collect();
        return Err(format!("firmware build failed for `{board}`: {}", tail.join(" | ")));
    }
    let elf = target_dir.join("thumbv7em-none-eabihf").join("release").join(format!("vt-firmware-{board}"));
    let bytes = fs::read(&elf).map_err(|e| format!("cannot read {}: {e}", elf.display()))?;
    elf_size(&bytes)
}

/// Runs the hook command and returns its JSON object.
///
/// # Errors
/// The command is missing, fails, times out, or prints no JSON object.
pub fn run_hook(paths: &Paths, command: Option<&str>) -> Result<Map<String, Value>, String> {
    let default = paths.root.join("firmware").join("bench.sh");
    let mut cmd = match command {
        Some(c) => {
            let mut k = Command::new("sh");
            k.args(["-c", c]);
            k
        }
        None if default.exists() => {
            let mut k = Command::new("sh");
            k.arg(&default);
            k
        }
        None => {
            return Err(format!(
                "{} is not there yet (hook for the firmware tooling; docs/benchmarks.md, \"MCU figures\")",
                rel(paths, &default)
            ))
        }
    };
    let mut child = cmd
        .current_dir(&paths.root)
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .map_err(|e| format!("cannot start the MCU hook: {e}"))?;
    let start = Instant::now();
    loop {
        match child.try_wait() {
            Ok(Some(_)) => break,
            Ok(None) if start.elapsed() > HOOK_TIMEOUT => {
                let _ = child.kill();
                return Err(format!("the MCU hook ran longer than {} s", HOOK_TIMEOUT.as_secs()));
            }
            Ok(None) => std::thread::sleep(Duration::from_millis(100)),
            Err(e) => return Err(format!("MCU hook: {e}")),
        }
    }
    let out = child.wait_with_output().map_err(|e| format!("MCU hook: {e}"))?;
    if !out.status.success() {
        return Err(format!("the MCU hook failed ({})", out.status));
    }
    let text = String::from_utf8_lossy(&out.stdout);
    let line = text
        .lines()
        .rev()
        .find(|l| l.trim_start().starts_with('{'))
        .ok_or("the MCU hook printed no JSON object")?;
    match serde_json::from_str::<Value>(line) {
        Ok(Value::Object(m)) => Ok(m),
        Ok(_) | Err(_) => Err("the MCU hook's last JSON line is not an object".into()),
    }
}

fn rel(paths: &Paths, p: &Path) -> String {
    p.strip_prefix(&paths.root).unwrap_or(p).display().to_string()
}

/// Flash budget of the firmware image, bytes (the project's: under 128 KiB).
pub const FLASH_BUDGET_BYTES: u64 = 128 * 1024;
/// Static RAM budget, bytes (the project's 32 KiB covers static RAM and the stack peak; the
/// stack peak is measured in QEMU by `firmware/bench.sh`, so this check is on static RAM alone).
pub const RAM_BUDGET_BYTES: u64 = 32 * 1024;

/// `cargo xtask firmware-size`: builds every board, prints flash and static RAM, and fails
/// (false) when an image is over [`FLASH_BUDGET_BYTES`] or [`RAM_BUDGET_BYTES`].
///
/// # Errors
/// A build failed or an ELF is unreadable.
pub fn size_check(paths: &Paths) -> Result<bool, String> {
    let mut ok = true;
    println!("{:<10} {:>12} {:>16}", "board", "flash [B]", "static RAM [B]");
    for board in BOARDS {
        let s = build_and_measure(paths, board)?;
        let over_flash = s.flash_bytes > FLASH_BUDGET_BYTES;
        let over_ram = s.static_ram_bytes > RAM_BUDGET_BYTES;
        println!(
            "{board:<10} {:>12} {:>16}{}{}",
            s.flash_bytes,
            s.static_ram_bytes,
            if over_flash { "  OVER the 128 KiB flash budget" } else { "" },
            if over_ram { "  OVER the 32 KiB RAM budget" } else { "" }
        );
        ok &= !(over_flash || over_ram);
    }
    Ok(ok)
}

#[cfg(test)]
#[allow(clippy::indexing_slicing)]
mod tests {
    use super::*;

    /// A minimal ELF32 with three sections: `.text` (alloc), `.data` (alloc + write),
    /// `.bss` (alloc + write, no bits), plus one non-alloc section.
    fn tiny_elf() -> Vec<u8> {
        let mut b = vec![0u8; 0x34];
        b[..6].copy_from_slice(&[0x7f, b'E', b'L', b'F', 1, 1]);
        let shoff = 0x34u32;
        b[0x20..0x24].copy_from_slice(&shoff.to_le_bytes());
        b[0x2E..0x30].copy_from_slice(&(SHDR_SIZE as u16).to_le_bytes());
        b[0x30..0x32].copy_from_slice(&4u16.to_le_bytes());
        let sections = [(1u32, SHF_ALLOC, 1000u32), (1, SHF_ALLOC | SHF_WRITE, 200), (SHT_NOBITS, SHF_ALLOC | SHF_WRITE, 300), (1, 0, 5000)];
        for (t, f, s) in sections {
            let mut h = vec![0u8; SHDR_SIZE];
            h[4..8].copy_from_slice(&t.to_le_bytes());
            h[8..12].copy_from_slice(&f.to_le_bytes());
            h[20..24].copy_from_slice(&s.to_le_bytes());
            b.extend(h);
        }
        b
    }

    #[test]
    fn elf_size_counts_flash_and_static_ram() {
        let s = elf_size(&tiny_elf()).unwrap_or(ImageSize { flash_bytes: 0, static_ram_bytes: 0 });
        assert_eq!(s, ImageSize { flash_bytes: 1200, static_ram_bytes: 500 });
    }

    #[test]
    fn elf_size_rejects_other_files() {
        assert!(elf_size(b"not an elf").is_err());
        let mut e = tiny_elf();
        e.truncate(0x40);
        assert!(elf_size(&e).is_err());
    }
}

