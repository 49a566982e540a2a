//! The board's row of `firmware/boards.toml`, as `build.rs` writes it: its Hello
//! name, core clock and whether it has the advisory line ([`NAME`],
//! [`CORE_CLOCK_HZ`], [`ADVISORY_LINE`]), which the board modules and the
//! application read.

include!(concat!(env!("OUT_DIR"), "/board.rs"));
