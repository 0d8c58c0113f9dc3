//! 8-bit sRGB colours.

/// An opaque 8-bit colour (sRGB values, no gamma handling: the renderer
/// scales the stored values linearly).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Rgb {
    /// Red.
    pub r: u8,
    /// Green.
    pub g: u8,
    /// Blue.
    pub b: u8,
}

/// An 8-bit colour with straight (not premultiplied) alpha; 255 is opaque.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Rgba {
    /// Red.
    pub r: u8,
    /// Green.
    pub g: u8,
    /// Blue.
    pub b: u8,
    /// Alpha (0 transparent, 255 opaque).
    pub a: u8,
}

impl Rgb {
    /// Black.
    pub const BLACK: Rgb = Rgb::new(0, 0, 0);
    /// White.
    pub const WHITE: Rgb = Rgb::new(255, 255, 255);

    /// The colour `(r, g, b)`.
    pub const fn new(r: u8, g: u8, b: u8) -> Self {
        Self { r, g, b }
    }

    /// The same colour, opaque.
    pub const fn opaque(self) -> Rgba {
        Rgba::new(self.r, self.g, self.b, 255)
    }

    /// Relative luminance of the stored values taken as linear,
    /// `Y = (0.2126 r + 0.7152 g + 0.0722 b) / 255` (Rec. 709 weights), in
    /// [0, 1].
    pub fn luminance(self) -> f64 {
        (0.2126 * f64::from(self.r) + 0.7152 * f64::from(self.g) + 0.0722 * f64::from(self.b))
            / 255.0
    }

    /// Every channel multiplied by `k` and rounded, clamped to [0, 255]
    /// (`c' = clamp(round(k c), 0, 255)`); a NaN `k` gives black.
    pub fn scaled(self, k: f64) -> Rgb {
        let f = |c: u8| to_u8(f64::from(c) * k);
        Rgb::new(f(self.r), f(self.g), f(self.b))
    }

    /// Linear interpolation `(1 - t) self + t other`, `t` clamped to [0, 1]
    /// (NaN taken as 0), rounded per channel.
    pub fn lerp(self, other: Rgb, t: f64) -> Rgb {
        let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
        let f = |a: u8, b: u8| to_u8(f64::from(a) + (f64::from(b) - f64::from(a)) * t);
        Rgb::new(f(self.r, other.r), f(self.g, other.g), f(self.b, other.b))
    }
}

impl Rgba {
    /// Opaque black.
    pub const BLACK: Rgba = Rgba::new(0, 0, 0, 255);
    /// Opaque white.
    pub const WHITE: Rgba = Rgba::new(255, 255, 255, 255);
    /// Fully transparent black.
    pub const TRANSPARENT: Rgba = Rgba::new(0, 0, 0, 0);

    /// The colour `(r, g, b, a)`.
    pub const fn new(r: u8, g: u8, b: u8, a: u8) -> Self {
        Self { r, g, b, a }
    }

    /// The colour without its alpha.
    pub const fn rgb(self) -> Rgb {
        Rgb::new(self.r, self.g, self.b)
    }
}

impl From<Rgb> for Rgba {
    fn from(c: Rgb) -> Self {
        c.opaque()
    }
}

/// `clamp(round(v), 0, 255)` as a byte; NaN gives 0.
pub(crate) fn to_u8(v: f64) -> u8 {
    if v.is_nan() {
        0
    } else {
        // `as` saturates; the clamp keeps the intent explicit.
        v.round().clamp(0.0, 255.0) as u8
    }
}
