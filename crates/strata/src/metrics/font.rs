//! A tiny 3x5 bitmap font for the digits 0–9, used by the heatmap legend.

/// Glyph cell width in font units.
pub(crate) const GLYPH_W: u32 = 3;
/// Glyph cell height in font units.
pub(crate) const GLYPH_H: u32 = 5;
/// Horizontal advance per character in font units (glyph plus one unit of spacing).
pub(crate) const ADVANCE: u32 = GLYPH_W + 1;

/// Rows top to bottom; in each row bit 2 is the left column, bit 0 the right column.
const DIGITS: [[u8; 5]; 10] = [
    [0b111, 0b101, 0b101, 0b101, 0b111], // 0
    [0b010, 0b110, 0b010, 0b010, 0b111], // 1
    [0b111, 0b001, 0b111, 0b100, 0b111], // 2
    [0b111, 0b001, 0b011, 0b001, 0b111], // 3
    [0b101, 0b101, 0b111, 0b001, 0b001], // 4
    [0b111, 0b100, 0b111, 0b001, 0b111], // 5
    [0b111, 0b100, 0b111, 0b101, 0b111], // 6
    [0b111, 0b001, 0b001, 0b010, 0b010], // 7
    [0b111, 0b101, 0b111, 0b101, 0b111], // 8
    [0b111, 0b101, 0b111, 0b001, 0b111], // 9
];

/// Width in font units of `text` set in this font (no trailing spacing); 0 for empty text.
pub(crate) fn text_width(text: &str) -> u32 {
    let n = text.chars().count() as u32;
    if n == 0 {
        0
    } else {
        n * ADVANCE - 1
    }
}

/// Calls `plot(col, row)` for every lit cell of `text`, in font units relative to the text's
/// top-left corner. Characters other than ASCII digits advance but draw nothing.
pub(crate) fn for_each_cell(text: &str, mut plot: impl FnMut(u32, u32)) {
    for (i, ch) in text.chars().enumerate() {
        let Some(d) = ch.to_digit(10) else { continue };
        let glyph = &DIGITS[d as usize];
        let x0 = i as u32 * ADVANCE;
        for (row, bits) in glyph.iter().enumerate() {
            for col in 0..GLYPH_W {
                if bits & (1 << (GLYPH_W - 1 - col)) != 0 {
                    plot(x0 + col, row as u32);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn glyphs_are_distinct_and_sized() {
        for (a, ga) in DIGITS.iter().enumerate() {
            for (b, gb) in DIGITS.iter().enumerate().skip(a + 1) {
                assert_ne!(ga, gb, "digits {a} and {b} look alike");
            }
        }
        assert_eq!(text_width(""), 0);
        assert_eq!(text_width("7"), 3);
        assert_eq!(text_width("128"), 11);
        let mut max_x = 0;
        let mut max_y = 0;
        let mut n = 0;
        for_each_cell("10", |x, y| {
            max_x = max_x.max(x);
            max_y = max_y.max(y);
            n += 1;
        });
        assert_eq!((max_x, max_y), (6, 4));
        assert_eq!(n, 8 + 12);
    }
}
