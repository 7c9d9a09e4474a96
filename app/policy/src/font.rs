//! The font every seespot figure is drawn with: DejaVu Sans, embedded in the
//! binary (`assets/DejaVuSans.ttf`, Bitstream Vera licence in
//! `assets/DejaVuSans-LICENSE.txt`), so figures are drawn, and drawn the same,
//! on machines without system fonts.

use std::sync::OnceLock;

use plotters::style::FontStyle;

/// DejaVu Sans, the TrueType bytes.
pub const DEJAVU_SANS: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");

/// Registers [`DEJAVU_SANS`] as plotters' `sans-serif` (once per process);
/// an error says why it could not be, and a figure should then be skipped
/// with a warning, never fail the command that draws it.
pub fn register() -> Result<(), String> {
    static DONE: OnceLock<Result<(), String>> = OnceLock::new();
    DONE.get_or_init(|| {
        plotters::style::register_font("sans-serif", FontStyle::Normal, DEJAVU_SANS)
            .map_err(|_| "the embedded DejaVu Sans font could not be parsed".to_owned())
    })
    .clone()
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_embedded_font_registers() {
        assert_eq!(super::register(), Ok(()));
    }
}
