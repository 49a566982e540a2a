#![no_std]
#![no_main]
use cortex_m as _;
use cortex_m_rt::entry;
use cortex_m_semihosting::{debug, hprintln};
use cortex_m::peripheral::syst::SystClkSource;
#[entry]
fn main() -> ! {
    let mut p = cortex_m::Peripherals::take().unwrap();
    p.SYST.set_clock_source(SystClkSource::Core);
    p.SYST.set_reload(0xFF_FFFF);
    p.SYST.clear_current();
    p.SYST.enable_counter();
    for n in [0u32, 1000, 10000, 100000] {
        let a = cortex_m::peripheral::SYST::get_current();
        cortex_m::asm::delay(n);
        let b = cortex_m::peripheral::SYST::get_current();
        hprintln!("delay {} ticks {}", n, a.wrapping_sub(b) & 0xFF_FFFF);
    }
    debug::exit(debug::EXIT_SUCCESS);
    loop {}
}
#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! { loop {} }
