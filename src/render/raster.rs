//! An RGB canvas and the few primitives the pictures need: filled rectangles, lines with
//! anti-aliasing, the pixels of a triangle, text in the built-in font, and copying one canvas
//! into another.
//!
//! Pixel (x, y) covers [x, x+1) × [y, y+1) with y growing downwards; shapes are given in those
//! continuous coordinates and sampled at pixel centres. A line's coverage of a pixel is
//! approximated by the distance from the pixel centre to the segment (a box filter of one pixel
//! across the line's edge), which is exact enough for lines of one to three pixels.

use glam::DVec2;

use super::font;

pub type Rgb = [u8; 3];

/// An 8-bit RGB picture, rows top to bottom, three bytes per pixel.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RgbImage {
    width: u32,
    height: u32,
    pixels: Vec<u8>,
}

impl RgbImage {
    /// A `width` × `height` picture filled with `colour`.
    pub fn new(width: u32, height: u32, colour: Rgb) -> Self {
        RgbImage {
            width,
            height,
            pixels: colour.repeat(width as usize * height as usize),
        }
    }

    pub fn width(&self) -> u32 {
        self.width
    }

    pub fn height(&self) -> u32 {
        self.height
    }

    /// The colour at (x, y); `None` outside the picture.
    pub fn pixel(&self, x: u32, y: u32) -> Option<Rgb> {
        let at = self.offset(x, y)?;
        Some([self.pixels[at], self.pixels[at + 1], self.pixels[at + 2]])
    }

    /// The bytes, R, G, B for each pixel, rows top to bottom (as PNG stores them).
    pub fn as_bytes(&self) -> &[u8] {
        &self.pixels
    }

    fn offset(&self, x: u32, y: u32) -> Option<usize> {
        (x < self.width && y < self.height)
            .then(|| 3 * (y as usize * self.width as usize + x as usize))
    }

    pub(crate) fn set(&mut self, x: u32, y: u32, colour: Rgb) {
        if let Some(at) = self.offset(x, y) {
            self.pixels[at..at + 3].copy_from_slice(&colour);
        }
    }

    /// Mixes `colour` into (x, y) with weight `alpha` (0–1).
    pub(crate) fn blend(&mut self, x: u32, y: u32, colour: Rgb, alpha: f64) {
        if let Some(at) = self.offset(x, y) {
            for (c, &target) in self.pixels[at..at + 3].iter_mut().zip(&colour) {
                *c = (*c as f64 + (target as f64 - *c as f64) * alpha).round() as u8;
            }
        }
    }

    /// Mixes `colour` into the rectangle of `width` × `height` pixels from (x, y), clipped.
    pub(crate) fn fill_rect(
        &mut self,
        x: i64,
        y: i64,
        width: i64,
        height: i64,
        colour: Rgb,
        alpha: f64,
    ) {
        for py in y.max(0)..(y + height).min(self.height as i64) {
            for px in x.max(0)..(x + width).min(self.width as i64) {
                self.blend(px as u32, py as u32, colour, alpha);
            }
        }
    }

    /// A line from `a` to `b`, `width` pixels wide, with anti-aliased edges and round ends.
    pub(crate) fn line(&mut self, a: DVec2, b: DVec2, width: f64, colour: Rgb) {
        let reach = 0.5 * width + 0.5;
        let lo = a.min(b) - reach;
        let hi = a.max(b) + reach;
        let x0 = lo.x.floor().max(0.0);
        let y0 = lo.y.floor().max(0.0);
        let x1 = hi.x.ceil().min(self.width as f64);
        let y1 = hi.y.ceil().min(self.height as f64);
        if !(x0 < x1 && y0 < y1) {
            return;
        }
        let ab = b - a;
        let length2 = ab.length_squared();
        for y in y0 as u32..y1 as u32 {
            for x in x0 as u32..x1 as u32 {
                let p = DVec2::new(x as f64 + 0.5, y as f64 + 0.5);
                let t = if length2 > 0.0 {
                    ((p - a).dot(ab) / length2).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let coverage = (reach - (p - (a + t * ab)).length()).clamp(0.0, 1.0);
                if coverage > 0.0 {
                    self.blend(x, y, colour, coverage);
                }
            }
        }
    }

    /// `text` in the built-in font with its top-left corner at (x, y), each font pixel a
    /// `scale` × `scale` square, on a dark translucent box so it reads over any image.
    pub(crate) fn text(&mut self, x: i64, y: i64, text: &str, scale: u32, colour: Rgb) {
        let s = scale as i64;
        let pad = s;
        self.fill_rect(
            x - pad,
            y - pad,
            font::text_width(text, scale) as i64 + 2 * pad,
            font::GLYPH_HEIGHT as i64 * s + 2 * pad,
            [0, 0, 0],
            0.55,
        );
        for (n, c) in text.chars().enumerate() {
            let left = x + n as i64 * font::ADVANCE as i64 * s;
            for (row, bits) in font::glyph(c).iter().enumerate() {
                for column in 0..font::GLYPH_WIDTH {
                    if bits >> (font::GLYPH_WIDTH - 1 - column) & 1 == 1 {
                        let px = left + column as i64 * s;
                        self.fill_rect(px, y + row as i64 * s, s, s, colour, 1.0);
                    }
                }
            }
        }
    }

    /// Copies `other` into this picture with its top-left corner at (x, y), clipped.
    pub(crate) fn draw_image(&mut self, other: &RgbImage, x: u32, y: u32) {
        for oy in 0..other.height.min(self.height.saturating_sub(y)) {
            let w = other.width.min(self.width.saturating_sub(x)) as usize;
            let from = 3 * oy as usize * other.width as usize;
            let to = 3 * ((y + oy) as usize * self.width as usize + x as usize);
            self.pixels[to..to + 3 * w].copy_from_slice(&other.pixels[from..from + 3 * w]);
        }
    }
}

/// Calls `visit(x, y, weights)` for every pixel of a `width` × `height` picture whose centre
/// lies in the triangle `corners` (edges included, either winding), with the centre's
/// barycentric weights. Degenerate triangles cover nothing.
pub(crate) fn triangle_pixels(
    width: u32,
    height: u32,
    corners: [DVec2; 3],
    mut visit: impl FnMut(u32, u32, [f64; 3]),
) {
    let [a, b, c] = corners;
    let edge = |p: DVec2, q: DVec2, r: DVec2| (q - p).perp_dot(r - p);
    let area = edge(a, b, c);
    if area.abs() < 1e-12 || !area.is_finite() {
        return;
    }
    let lo = a.min(b).min(c);
    let hi = a.max(b).max(c);
    let x0 = (lo.x - 0.5).ceil().max(0.0);
    let y0 = (lo.y - 0.5).ceil().max(0.0);
    let x1 = (hi.x - 0.5).floor().min(width as f64 - 1.0);
    let y1 = (hi.y - 0.5).floor().min(height as f64 - 1.0);
    if !(x0 <= x1 && y0 <= y1) {
        return;
    }
    for y in y0 as u32..=y1 as u32 {
        for x in x0 as u32..=x1 as u32 {
            let p = DVec2::new(x as f64 + 0.5, y as f64 + 0.5);
            let wa = edge(b, c, p) / area;
            let wb = edge(c, a, p) / area;
            let wc = 1.0 - wa - wb;
            if wa >= 0.0 && wb >= 0.0 && wc >= 0.0 {
                visit(x, y, [wa, wb, wc]);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const WHITE: Rgb = [255, 255, 255];

    fn inked(image: &RgbImage) -> usize {
        image
            .as_bytes()
            .chunks(3)
            .filter(|p| p != &[0, 0, 0])
            .count()
    }

    #[test]
    fn a_line_is_about_its_width_across_and_soft_at_its_edges() {
        let mut image = RgbImage::new(40, 20, [0, 0, 0]);
        image.line(DVec2::new(5.0, 10.5), DVec2::new(35.0, 10.5), 1.5, WHITE);
        let column: Vec<u8> = (0..20).map(|y| image.pixel(20, y).unwrap()[0]).collect();
        let ink: f64 = column.iter().map(|&v| v as f64 / 255.0).sum();
        assert!((ink - 1.5).abs() < 0.05, "{column:?}");
        assert_eq!(column[10], 255);
        assert!(
            column[9] > 0 && column[9] < 255,
            "no anti-aliasing: {column:?}"
        );
        assert_eq!(column[9], column[11]);
        assert_eq!(image.pixel(2, 10), Some([0, 0, 0]));
    }

    #[test]
    fn lines_far_outside_and_degenerate_triangles_draw_nothing() {
        let mut image = RgbImage::new(10, 10, [0, 0, 0]);
        image.line(
            DVec2::new(-50.0, -5.0),
            DVec2::new(-20.0, -30.0),
            2.0,
            WHITE,
        );
        image.line(DVec2::new(f64::NAN, 1.0), DVec2::new(3.0, 3.0), 2.0, WHITE);
        assert_eq!(inked(&image), 0);
        let flat = [DVec2::ZERO, DVec2::new(5.0, 5.0), DVec2::new(10.0, 10.0)];
        triangle_pixels(10, 10, flat, |_, _, _| {
            panic!("a flat triangle covers nothing")
        });
    }

    #[test]
    fn a_triangle_covers_about_its_area_with_weights_summing_to_one() {
        for corners in [
            [
                DVec2::new(2.0, 3.0),
                DVec2::new(30.0, 5.0),
                DVec2::new(10.0, 28.0),
            ],
            [
                DVec2::new(2.0, 3.0),
                DVec2::new(10.0, 28.0),
                DVec2::new(30.0, 5.0),
            ],
        ] {
            let mut count = 0;
            triangle_pixels(32, 32, corners, |_, _, w| {
                assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-12);
                count += 1;
            });
            let area = 0.5
                * (corners[1] - corners[0])
                    .perp_dot(corners[2] - corners[0])
                    .abs();
            assert!(
                (count as f64 - area).abs() < 0.1 * area,
                "{count} vs {area}"
            );
        }
    }

    #[test]
    fn two_triangles_sharing_an_edge_leave_no_gap() {
        let (a, b, c, d) = (
            DVec2::new(0.3, 0.2),
            DVec2::new(15.7, 0.9),
            DVec2::new(14.2, 15.6),
            DVec2::new(1.1, 14.8),
        );
        let mut image = RgbImage::new(16, 16, [0, 0, 0]);
        for tri in [[a, b, c], [a, c, d]] {
            triangle_pixels(16, 16, tri, |x, y, _| image.set(x, y, WHITE));
        }
        // Every pixel centre inside the quad is covered.
        for y in 2..14 {
            for x in 2..14 {
                assert_eq!(image.pixel(x, y), Some(WHITE), "gap at {x},{y}");
            }
        }
    }

    #[test]
    fn text_inks_its_glyphs_and_copies_are_clipped() {
        let mut label = RgbImage::new(40, 12, [0, 0, 0]);
        label.text(1, 1, "1", 1, WHITE);
        // The '1' has 10 pixels of ink.
        assert_eq!(
            label.as_bytes().chunks(3).filter(|p| p == &WHITE).count(),
            10
        );
        let mut big = RgbImage::new(50, 20, [9, 9, 9]);
        big.draw_image(&label, 30, 15);
        assert_eq!(big.pixel(30, 15), label.pixel(0, 0));
        assert_eq!(big.pixel(29, 15), Some([9, 9, 9]));
    }
}
