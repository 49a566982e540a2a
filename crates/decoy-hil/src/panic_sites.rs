//! The panic sites a firmware ELF keeps: every branch (Thumb-2 `BL`, `B.W`,
//! conditional `B`, and their 16-bit forms) whose target is one of the core
//! library's panic entry points (`core::panicking::*`, the slice and
//! `RefCell` failures, `unwrap`'s and `expect`'s), with the function that
//! holds it. `hil-tests/tests/panic_free.rs` reads the firmware's
//! `examples/panic_never.rs` build (the serve loop with `handle` and
//! `background`, nothing else) with it and holds every site to a documented
//! list (firmware/README.md, "No panic in flight").
//!
//! The functions are the linked ones: after inlining, a site of a library's
//! code (heapless, cobs) is attributed to the function of this workspace it was
//! inlined into.

use std::collections::BTreeMap;
use std::path::Path;

use object::{Object, ObjectSection, ObjectSymbol, SymbolKind};

/// One branch to a panic entry point.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct PanicSite {
    /// The function holding the branch (demangled, without its hash).
    pub function: String,
    /// The panic entry point it branches to (demangled, without its hash).
    pub target: String,
    /// The branch's address.
    pub address: u64,
}

/// Parts of a mangled symbol name that make it a panic entry point.
const PANIC_ENTRY_MARKS: [&str; 9] = [
    "9panicking",
    "slice_index_fail",
    "slice_start_index",
    "slice_end_index",
    "panic_already_borrowed",
    "panic_already_mutably_borrowed",
    "unwrap_failed",
    "expect_failed",
    "rust_begin_unwind",
];

/// The legacy Rust mangling `_ZN<len><part>...17h<hash>E` as `a::b::c` (other
/// names as they are).
pub fn demangle(name: &str) -> String {
    let Some(mut rest) = name.strip_prefix("_ZN") else {
        return name.to_owned();
    };
    let mut parts = Vec::new();
    while let Some(digits) = rest.find(|c: char| !c.is_ascii_digit()).filter(|&d| d > 0) {
        let Ok(len) = rest[..digits].parse::<usize>() else {
            break;
        };
        let Some(part) = rest.get(digits..digits + len) else {
            break;
        };
        rest = &rest[digits + len..];
        let is_hash = part.len() == 17
            && part.starts_with('h')
            && part[1..].chars().all(|c| c.is_ascii_hexdigit());
        if !is_hash {
            parts.push(
                part.replace("$LT$", "<")
                    .replace("$GT$", ">")
                    .replace("$C$", ",")
                    .replace("$u20$", " ")
                    .replace("..", "::"),
            );
        }
    }
    if parts.is_empty() {
        name.to_owned()
    } else {
        parts.join("::")
    }
}

/// The target of the Thumb branch at `address` made of the halfwords `first`
/// and `second` (the second unused for a 16-bit instruction), with the
/// instruction's size: `None` for anything but a branch.
fn branch_target(address: u64, first: u16, second: u16) -> Option<(u64, u64)> {
    let pc = address as i64 + 4;
    let sign_extend = |value: u32, bits: u32| -> i64 {
        let shift = 32 - bits;
        i64::from(((value << shift) as i32) >> shift)
    };
    if first >> 11 == 0b11110 && second >> 15 == 1 {
        let s = u32::from((first >> 10) & 1);
        let j1 = u32::from((second >> 13) & 1);
        let j2 = u32::from((second >> 11) & 1);
        let imm11 = u32::from(second & 0x7ff);
        let op = (second >> 12) & 0b101;
        if op == 0b101 || op == 0b001 {
            // BL (T1) and B.W (T4): S:I1:I2:imm10:imm11:0.
            let i1 = 1 ^ (j1 ^ s);
            let i2 = 1 ^ (j2 ^ s);
            let imm10 = u32::from(first & 0x3ff);
            let value = (s << 24) | (i1 << 23) | (i2 << 22) | (imm10 << 12) | (imm11 << 1);
            return Some(((pc + sign_extend(value, 25)) as u64, 4));
        }
        if op == 0b000 && (first >> 6) & 0b1110 != 0b1110 {
            // Conditional B (T3): S:J2:J1:imm6:imm11:0.
            let imm6 = u32::from(first & 0x3f);
            let value = (s << 20) | (j2 << 19) | (j1 << 18) | (imm6 << 12) | (imm11 << 1);
            return Some(((pc + sign_extend(value, 21)) as u64, 4));
        }
        return None;
    }
    if first >> 12 == 0b1101 && (first >> 8) & 0xf < 0xe {
        // Conditional B (T1).
        let value = u32::from(first & 0xff) << 1;
        return Some(((pc + sign_extend(value, 9)) as u64, 2));
    }
    if first >> 11 == 0b11100 {
        // B (T2).
        let value = u32::from(first & 0x7ff) << 1;
        return Some(((pc + sign_extend(value, 12)) as u64, 2));
    }
    None
}

/// Whether a halfword starts a 32-bit Thumb-2 instruction.
fn is_wide(first: u16) -> bool {
    matches!(first >> 11, 0b11101..=0b11111)
}

/// Every panic site of the ELF at `elf`, sorted by function then address.
/// The panic entry points themselves and the core library's own functions
/// (which only panic on behalf of their callers) are left out.
pub fn panic_sites(elf: &Path) -> Result<Vec<PanicSite>, String> {
    let data = std::fs::read(elf).map_err(|e| format!("cannot read {}: {e}", elf.display()))?;
    let file =
        object::File::parse(&*data).map_err(|e| format!("{}: not an ELF: {e}", elf.display()))?;
    let mut functions: Vec<(u64, u64, String)> = Vec::new();
    let mut entries: BTreeMap<u64, String> = BTreeMap::new();
    for symbol in file.symbols() {
        if symbol.kind() != SymbolKind::Text || symbol.size() == 0 {
            continue;
        }
        let Ok(name) = symbol.name() else { continue };
        let address = symbol.address() & !1;
        if PANIC_ENTRY_MARKS.iter().any(|m| name.contains(m)) {
            entries.insert(address, demangle(name));
        } else {
            functions.push((address, symbol.size(), demangle(name)));
        }
    }
    if entries.is_empty() {
        return Ok(Vec::new());
    }
    let text = file
        .section_by_name(".text")
        .ok_or_else(|| format!("{}: no .text section", elf.display()))?;
    let base = text.address();
    let bytes = text
        .data()
        .map_err(|e| format!("{}: cannot read .text: {e}", elf.display()))?;
    let halfword = |address: u64| -> Option<u16> {
        let offset = usize::try_from(address.checked_sub(base)?).ok()?;
        let b = bytes.get(offset..offset + 2)?;
        Some(u16::from_le_bytes([b[0], b[1]]))
    };
    let mut sites = Vec::new();
    for (start, size, function) in &functions {
        if function.starts_with("core::") {
            continue;
        }
        let mut address = *start;
        while address < start + size {
            let Some(first) = halfword(address) else {
                break;
            };
            let second = halfword(address + 2).unwrap_or(0);
            let step = if is_wide(first) { 4 } else { 2 };
            if let Some((target, _)) = branch_target(address, first, second)
                && let Some(entry) = entries.get(&target)
            {
                sites.push(PanicSite {
                    function: function.clone(),
                    target: entry.clone(),
                    address,
                });
            }
            address += step;
        }
    }
    sites.sort();
    Ok(sites)
}

/// The sites counted per function.
pub fn by_function(sites: &[PanicSite]) -> BTreeMap<String, usize> {
    let mut counts = BTreeMap::new();
    for s in sites {
        *counts.entry(s.function.clone()).or_insert(0) += 1;
    }
    counts
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn legacy_names_demangle() {
        assert_eq!(
            demangle("_ZN4core9panicking18panic_bounds_check17h0123456789abcdefE"),
            "core::panicking::panic_bounds_check"
        );
        assert_eq!(
            demangle("_ZN11solver_core8dynamics8evaluate17h649035b7f2572accE"),
            "solver_core::dynamics::evaluate"
        );
        assert_eq!(demangle("main"), "main");
    }

    #[test]
    fn thumb_branches_decode() {
        // bl 0x18064 at 0x9ad8 (from a firmware disassembly).
        let (first, second) = (0xf00e_u16, 0xfac4_u16);
        assert_eq!(branch_target(0x9ad8, first, second), Some((0x18064, 4)));
        // bhs.w 0x9acc at 0x943e: f080 8345.
        assert_eq!(branch_target(0x943e, 0xf080, 0x8345), Some((0x9acc, 4)));
        // b 0x9a8c at 0x9a72 (16-bit): e00b.
        assert_eq!(branch_target(0x9a72, 0xe00b, 0), Some((0x9a8c, 2)));
        // beq 0x9456 at 0x9434 (16-bit): d00f.
        assert_eq!(branch_target(0x9434, 0xd00f, 0), Some((0x9456, 2)));
        // Not a branch: vstr.
        assert_eq!(branch_target(0x944a, 0xed80, 0x3a00), None);
    }
}
