//! Firmware image sizes read from an ELF's section headers: flash (every allocated section
//! with file data) and static RAM (allocated and writable: `.data`, `.bss`, `.uninit`), and
//! the project's memory budgets. Used by `cargo xtask firmware-size` and by the PIL tests,
//! which add a real flight's stack high-water mark to the static RAM.

/// ELF section flag: writable.
const SHF_WRITE: u32 = 0x1;
/// ELF section flag: occupies memory at run time.
const SHF_ALLOC: u32 = 0x2;
/// ELF section type: no file data (`.bss`).
const SHT_NOBITS: u32 = 8;
/// Size of an ELF32 section header, bytes.
const SHDR_SIZE: usize = 40;
/// Flash budget of the firmware image, bytes (the project's: under 128 KiB).
pub const FLASH_BUDGET_BYTES: u64 = 128 * 1024;
/// Static RAM budget, bytes (the project's 32 KiB covers static RAM and the stack peak; the
/// stack peak is measured in a PIL flight in QEMU, `tests/pil.rs`).
pub const RAM_BUDGET_BYTES: u64 = 32 * 1024;

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

/// Bytes of an ELF's sections whose names start with `prefix` (the perception build's
/// core-coupled RAM: `.ccmbss`).
///
/// # Errors
/// Not an ELF the `object` crate reads.
pub fn section_bytes(bytes: &[u8], prefix: &str) -> Result<u64, String> {
    use object::{Object, ObjectSection};
    let file = object::File::parse(bytes).map_err(|e| format!("not an ELF: {e}"))?;
    Ok(file.sections().filter(|s| s.name().is_ok_and(|n| n.starts_with(prefix))).map(|s| s.size()).sum())
}

/// The highest stack high-water mark a firmware log reports, bytes (the firmware logs
/// "stack high-water mark N bytes" each time the painted stack's mark rises, and once more at
/// shutdown), or `None` when the log has none.
#[must_use]
pub fn stack_high_water_bytes(log: &[String]) -> Option<u64> {
    log.iter().filter_map(|l| super::bench::parse_after(l, "stack high-water mark ")).max()
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
    fn the_stack_high_water_mark_is_the_highest_logged() {
        let log = ["stack high-water mark 900 bytes", "tick", "stack high-water mark 11480 bytes", "shutdown requested; stack high-water mark 11480 bytes"];
        assert_eq!(stack_high_water_bytes(&log.map(String::from)), Some(11_480));
        assert_eq!(stack_high_water_bytes(&["no stack here".to_string()]), None);
    }

    #[test]
    fn section_bytes_sums_the_sections_of_a_prefix() {
        // This test's own executable (an ELF on Linux): its code, and no section of a made-up name.
        let exe = std::fs::read(std::env::current_exe().unwrap()).unwrap();
        assert!(section_bytes(&exe, ".text").unwrap() > 1000);
        assert_eq!(section_bytes(&exe, ".no-such-section").unwrap(), 0);
        assert!(section_bytes(b"not an elf", ".text").is_err());
    }

    #[test]
    fn elf_size_rejects_other_files() {
        assert!(elf_size(b"not an elf").is_err());
        let mut e = tiny_elf();
        e.truncate(0x40);
        assert!(elf_size(&e).is_err());
    }
}
