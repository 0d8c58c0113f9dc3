//! Text layout shared by the figures of every organ: text wrapped into
//! lines ([`wrap`]), a line fitted into a width (the largest scale that
//! fits, else cut with `...`: [`fit`], [`text_fit`]), the title band at
//! the top of a panel or figure ([`TitleStyle`], [`title_band`]), and
//! panels ([`panel`]) composed into one figure ([`compose`]).
//!
//! Text is the renderer's 8x8 bitmap font: a line of `n` characters at
//! scale `s` is `8 s n` pixels wide and `8 s` high.

use unfold_render::{Anchor, Image, RenderError, Rgba, text_width};

use super::{FigureOptions, INK, PAPER};

/// Width of one character at text scale 1, pixels.
const CHAR_WIDTH: u32 = 8;

/// What marks the end of text that was cut.
const ELLIPSIS: &str = "...";

/// Splits `text` into lines of at most `max_chars` characters (at least 1):
/// at white space, and inside a longer word after an underscore or, failing
/// that, anywhere (so that array names like `coaptation_distance_mm` break
/// at their parts). Words are joined by single spaces; empty text gives no
/// line.
pub fn wrap(text: &str, max_chars: usize) -> Vec<String> {
    let max = max_chars.max(1);
    let mut pieces: Vec<String> = Vec::new();
    for word in text.split_whitespace() {
        if word.chars().count() <= max {
            pieces.push(word.to_string());
            continue;
        }
        let mut cur = String::new();
        for part in word.split_inclusive('_') {
            if cur.chars().count() + part.chars().count() > max && !cur.is_empty() {
                pieces.push(std::mem::take(&mut cur));
            }
            cur.push_str(part);
            while cur.chars().count() > max {
                let head: String = cur.chars().take(max).collect();
                cur = cur.chars().skip(max).collect();
                pieces.push(head);
            }
        }
        if !cur.is_empty() {
            pieces.push(cur);
        }
    }
    let mut lines: Vec<String> = Vec::new();
    for p in pieces {
        match lines.last_mut() {
            Some(l) if l.chars().count() + 1 + p.chars().count() <= max => {
                l.push(' ');
                l.push_str(&p);
            }
            _ => lines.push(p),
        }
    }
    lines
}

/// The largest text scale `s`, `1 <= s <= max_scale`, at which `text` is at
/// most `max_width` pixels wide (`8 s n <= max_width` for `n` characters);
/// 1 when it fits at none.
pub fn fit_scale(text: &str, max_scale: u32, max_width: u32) -> u32 {
    let mut scale = max_scale.max(1);
    while scale > 1 && text_width(text, scale) > max_width {
        scale -= 1;
    }
    scale
}

/// `text` fitted into `max_width` pixels: the scale of [`fit_scale`] and the
/// text itself, or, when it does not fit even at scale 1, its first
/// `floor(max_width / 8) - 3` characters followed by `...` (only the first
/// `floor(max_width / 8)` characters when that leaves no room for `...`).
pub fn fit(text: &str, max_scale: u32, max_width: u32) -> (u32, String) {
    let scale = fit_scale(text, max_scale, max_width);
    if text_width(text, scale) <= max_width {
        return (scale, text.to_string());
    }
    let n = (max_width / CHAR_WIDTH) as usize;
    let cut = if n > ELLIPSIS.len() {
        text.chars()
            .take(n - ELLIPSIS.len())
            .chain(ELLIPSIS.chars())
            .collect()
    } else {
        text.chars().take(n).collect()
    };
    (scale, cut)
}

/// Draws `text` in [`INK`] fitted into `max_width` pixels ([`fit`], at most
/// `max_scale`) with its top at row `y` and its reference point at column
/// `x` (left end, middle or right end by `anchor`).
pub fn text_fit(
    img: &mut Image,
    x: i32,
    y: i32,
    text: &str,
    max_scale: u32,
    max_width: u32,
    anchor: Anchor,
) -> Result<(), RenderError> {
    let (scale, shown) = fit(text, max_scale, max_width);
    img.draw_text(x, y, &shown, scale, INK, anchor)?;
    Ok(())
}

/// Where a title band puts its text: a title (in [`INK`], centred, at the
/// largest scale that fits) and below it a subtitle (scale 1, centred,
/// wrapped into a few lines). Each organ's figures have their own style.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TitleStyle {
    /// Row of the top of the title.
    pub title_top: i32,
    /// Pixels kept free beside the title and the subtitle, both sides
    /// together: the text is at most `width - margin` wide.
    pub margin: u32,
    /// Row of the top of the first subtitle line.
    pub subtitle_top: i32,
    /// Rows from one subtitle line to the next.
    pub line_step: i32,
    /// Most subtitle lines (at least 1): text beyond them is dropped and
    /// the last line shown ends in `...`.
    pub subtitle_lines: usize,
    /// Colour of the subtitle.
    pub subtitle_ink: Rgba,
}

impl TitleStyle {
    /// Room for the text in a band `width` pixels wide: `width - margin`.
    fn room(&self, width: u32) -> u32 {
        width.saturating_sub(self.margin)
    }

    /// The largest title scale, at most `max_scale`, at which every one of
    /// `titles` fits a band `width` pixels wide (so that the panels of a
    /// figure can share it): the smallest [`fit_scale`] of them.
    pub fn shared_scale(&self, width: u32, titles: &[&str], max_scale: u32) -> u32 {
        titles
            .iter()
            .map(|t| fit_scale(t, max_scale, self.room(width)))
            .min()
            .unwrap_or(max_scale.max(1))
    }
}

/// Draws a title band across the top of `img` in `style`: `title` at the
/// largest scale up to `max_title_scale` that fits (cut with `...` at scale
/// 1 if none does), `subtitle` wrapped ([`wrap`]) into at most
/// `style.subtitle_lines` lines below it. Nothing is drawn for an empty
/// subtitle.
pub fn title_band(
    img: &mut Image,
    style: &TitleStyle,
    title: &str,
    max_title_scale: u32,
    subtitle: &str,
) -> Result<(), RenderError> {
    let w = img.width();
    let (cx, room) = ((w / 2) as i32, style.room(w));
    text_fit(
        img,
        cx,
        style.title_top,
        title,
        max_title_scale,
        room,
        Anchor::Center,
    )?;
    let max_lines = style.subtitle_lines.max(1);
    let mut lines = wrap(subtitle, (room / CHAR_WIDTH).max(1) as usize);
    if lines.len() > max_lines {
        lines.truncate(max_lines);
        if let Some(last) = lines.last_mut() {
            last.push_str(ELLIPSIS);
        }
    }
    for (k, line) in lines.iter().enumerate() {
        let (_, shown) = fit(line, 1, room);
        let y = style.subtitle_top + style.line_step * k as i32;
        img.draw_text(cx, y, &shown, 1, style.subtitle_ink, Anchor::Center)?;
    }
    Ok(())
}

/// A blank panel of the size `opts` gives, on [`PAPER`], with its title
/// band ([`title_band`]) and a one-pixel outline in `outline`.
pub fn panel(
    opts: &FigureOptions,
    style: &TitleStyle,
    title: &str,
    max_title_scale: u32,
    subtitle: &str,
    outline: Rgba,
) -> Result<Image, RenderError> {
    let mut img = Image::new(opts.panel_width, opts.panel_height, PAPER)?;
    title_band(&mut img, style, title, max_title_scale, subtitle)?;
    img.stroke_rect(img.rect(), outline);
    Ok(img)
}

/// `panels` of `panel_width x panel_height` pixels each (row-major,
/// `columns` per row) composed into one figure on [`PAPER`].
pub fn compose(panels: &[Image], columns: u32, opts: &FigureOptions) -> Result<Image, RenderError> {
    let columns = columns.max(1);
    let rows = (panels.len() as u32).div_ceil(columns);
    let (w, h) = (opts.panel_width, opts.panel_height);
    let mut fig = Image::new(w.saturating_mul(columns), h.saturating_mul(rows), PAPER)?;
    for (k, p) in panels.iter().enumerate() {
        let (c, r) = (k as u32 % columns, k as u32 / columns);
        fig.blit(p, i64::from(c * w), i64::from(r * h));
    }
    Ok(fig)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrap_splits_at_spaces() {
        assert_eq!(
            wrap("wall thickness in mm", 10),
            vec!["wall", "thickness", "in mm"]
        );
        assert_eq!(wrap("", 10), Vec::<String>::new());
        assert_eq!(wrap("  two   spaces ", 20), vec!["two spaces"]);
    }

    #[test]
    fn wrap_breaks_long_words_after_underscores_then_anywhere() {
        assert_eq!(
            wrap("coaptation_distance_mm of the valve", 12),
            vec!["coaptation_", "distance_mm", "of the valve"]
        );
        assert_eq!(wrap("abcdefghij", 4), vec!["abcd", "efgh", "ij"]);
        assert_eq!(wrap("a b", 0), vec!["a", "b"]);
    }

    #[test]
    fn fit_takes_the_largest_scale_then_cuts() {
        assert_eq!(fit_scale("abcd", 2, 64), 2);
        assert_eq!(fit_scale("abcd", 2, 63), 1);
        assert_eq!(fit_scale("abcd", 0, 8), 1);
        assert_eq!(fit("abcd", 2, 32), (1, "abcd".to_string()));
        assert_eq!(fit("abcdefghij", 2, 48), (1, "abc...".to_string()));
        assert_eq!(fit("abcdefghij", 1, 24), (1, "abc".to_string()));
    }

    #[test]
    fn a_title_band_drops_what_does_not_fit_with_an_ellipsis() {
        let style = TitleStyle {
            title_top: 2,
            margin: 0,
            subtitle_top: 12,
            line_step: 10,
            subtitle_lines: 1,
            subtitle_ink: INK,
        };
        let mut img = Image::new(80, 24, PAPER).unwrap();
        title_band(&mut img, &style, "T", 2, "one two three").unwrap();
        // "one two" fits the 10 characters, "three" does not: "one two..."
        // fills the whole row of the subtitle.
        let inked = |x0: u32, x1: u32| {
            (x0..x1).any(|x| (12..20).any(|y| img.get(i64::from(x), y) == Some(INK)))
        };
        assert!(inked(0, 8) && inked(72, 80));
        assert_eq!(style.shared_scale(80, &["abcd", "abcde"], 2), 2);
        assert_eq!(style.shared_scale(80, &["abcd", "abcdef"], 2), 1);
    }
}
