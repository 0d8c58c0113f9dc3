//! Colour maps (from `colorous`) and value-to-colour scales.

use crate::Rgb;

/// The colour [`ColorScale::color`] gives to NaN values: a neutral grey.
pub const NAN_COLOR: Rgb = Rgb::new(160, 160, 160);

/// A colour map: a function from `t` in [0, 1] to a colour.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Colormap {
    /// Viridis, perceptually uniform sequential (dark blue to yellow);
    /// luminance increases with `t`.
    #[default]
    Viridis,
    /// Magma, perceptually uniform sequential (black to light yellow).
    Magma,
    /// Cividis, sequential and readable with colour-vision deficiencies.
    Cividis,
    /// Greys, sequential from white to black.
    Greys,
    /// Diverging blue (low) - white (middle) - red (high): ColorBrewer's
    /// RdBu reversed.
    BlueRed,
    /// Diverging purple (low) - white - orange (high): ColorBrewer's PuOr
    /// reversed.
    PurpleOrange,
    /// Categorical: the 10 colours of Tableau 10, for integer labels.
    Tableau10,
    /// Categorical: the 10 colours of D3's Category 10.
    Category10,
}

impl Colormap {
    /// Whether the map is a categorical palette (meant for [`Colormap::label`]).
    pub fn is_categorical(self) -> bool {
        matches!(self, Colormap::Tableau10 | Colormap::Category10)
    }

    /// The colour at `t`, clamped to [0, 1] (NaN taken as 0).
    ///
    /// Continuous maps sample their gradient; a reversed map evaluates the
    /// original at `1 - t`. A categorical palette of `n` colours is a step
    /// function: colour `min(floor(t n), n - 1)`.
    pub fn eval(self, t: f64) -> Rgb {
        let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
        let c = match self {
            Colormap::Viridis => colorous::VIRIDIS.eval_continuous(t),
            Colormap::Magma => colorous::MAGMA.eval_continuous(t),
            Colormap::Cividis => colorous::CIVIDIS.eval_continuous(t),
            Colormap::Greys => colorous::GREYS.eval_continuous(t),
            Colormap::BlueRed => colorous::RED_BLUE.eval_continuous(1.0 - t),
            Colormap::PurpleOrange => colorous::PURPLE_ORANGE.eval_continuous(1.0 - t),
            Colormap::Tableau10 | Colormap::Category10 => {
                let n = 10.0;
                return self.label((t * n).floor().min(n - 1.0) as usize);
            }
        };
        Rgb::new(c.r, c.g, c.b)
    }

    /// The colour of integer label `i`. Categorical palettes return colour
    /// `i mod 10` (wrapping); continuous maps return
    /// `eval(((i mod 10) + 0.5) / 10)`, ten evenly spaced samples.
    pub fn label(self, i: usize) -> Rgb {
        let k = i % 10;
        let c = match self {
            Colormap::Tableau10 => colorous::TABLEAU10[k],
            Colormap::Category10 => colorous::CATEGORY10[k],
            _ => return self.eval((k as f64 + 0.5) / 10.0),
        };
        Rgb::new(c.r, c.g, c.b)
    }
}

/// Maps values to colours: `v` goes to `map.eval((v - lo) / (hi - lo))`,
/// clamped to the ends of the map; NaN goes to [`NAN_COLOR`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ColorScale {
    /// The colour map.
    pub map: Colormap,
    /// The value shown at the low end of the map.
    pub lo: f64,
    /// The value shown at the high end of the map.
    pub hi: f64,
}

impl ColorScale {
    /// The scale `[lo, hi]` on `map`.
    pub fn new(map: Colormap, lo: f64, hi: f64) -> Self {
        Self { map, lo, hi }
    }

    /// A scale from the smallest to the largest finite value of `values`
    /// (`[0, 1]` if there is none).
    pub fn from_values(map: Colormap, values: &[f64]) -> Self {
        let (lo, hi) = finite_range(values).unwrap_or((0.0, 1.0));
        Self { map, lo, hi }
    }

    /// A scale `[-m, m]` symmetric about 0 with `m` the largest finite `|v|`
    /// (`m = 1` if there is none or it is 0), for diverging maps.
    pub fn symmetric(map: Colormap, values: &[f64]) -> Self {
        let m = values
            .iter()
            .filter(|v| v.is_finite())
            .fold(0.0f64, |m, v| m.max(v.abs()));
        let m = if m > 0.0 { m } else { 1.0 };
        Self { map, lo: -m, hi: m }
    }

    /// The position `t = (v - lo) / (hi - lo)` of `v` on the map, clamped to
    /// [0, 1]; `t = 0.5` when `hi == lo`; `None` for NaN `v` or a scale
    /// with a non-finite end.
    pub fn position(&self, v: f64) -> Option<f64> {
        if v.is_nan() || !self.lo.is_finite() || !self.hi.is_finite() {
            return None;
        }
        let d = self.hi - self.lo;
        let t = if d == 0.0 { 0.5 } else { (v - self.lo) / d };
        if t.is_nan() {
            None
        } else {
            Some(t.clamp(0.0, 1.0))
        }
    }

    /// The colour of `v`: `map.eval(position(v))`, or [`NAN_COLOR`] when
    /// [`ColorScale::position`] is `None`.
    pub fn color(&self, v: f64) -> Rgb {
        self.position(v).map_or(NAN_COLOR, |t| self.map.eval(t))
    }

    /// [`ColorScale::color`] of every value.
    pub fn colors(&self, values: &[f64]) -> Vec<Rgb> {
        values.iter().map(|&v| self.color(v)).collect()
    }
}

/// `(min, max)` of the finite values, or `None` if there is none.
pub(crate) fn finite_range(values: &[f64]) -> Option<(f64, f64)> {
    values
        .iter()
        .filter(|v| v.is_finite())
        .fold(None, |acc, &v| match acc {
            None => Some((v, v)),
            Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
        })
}

/// A short label for a number: `0` for zero; scientific notation with 2
/// decimals (`1.23e5`) when `|v| >= 10^4` or `|v| < 10^-2`; otherwise 3
/// significant digits with trailing zeros removed (`0.5`, `12.3`, `100`).
/// Non-finite values print as `nan`, `inf`, `-inf`.
pub fn format_value(v: f64) -> String {
    if v.is_nan() {
        return "nan".into();
    }
    if v.is_infinite() {
        return if v > 0.0 { "inf".into() } else { "-inf".into() };
    }
    if v == 0.0 {
        return "0".into();
    }
    let a = v.abs();
    if !(1e-2..1e4).contains(&a) {
        return format!("{v:.2e}");
    }
    let digits = (2 - a.log10().floor() as i32).clamp(0, 4) as usize;
    let s = format!("{v:.digits$}");
    let s = if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    };
    if s == "-0" { "0".into() } else { s }
}
