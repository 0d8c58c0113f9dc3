//! Text layout shared by the figures of every organ: text wrapped into
//! lines ([`wrap`]), a line fitted into a width (the largest scale that
//! fits, else cut with `...`: [`fit`], [`text_fit`]), the title band at
//! the top of a panel or figure ([`TitleStyle`], [`title_band`]), and
//! panels ([`panel`]) composed into one figure ([`compose`]).
//!
//! Text is the renderer's proportional font (Noto Sans): every width is
//! measured with [`text_width`], never counted in characters.

use unfold_render::{Anchor, Image, RenderError, Rgba, text_width};

use super::{FigureOptions, INK, PAPER};

/// What marks the end of text that was cut.
const ELLIPSIS: &str = "...";

/// The longest prefix of `text` (in characters) that is at most `max_width`
/// pixels wide at `scale`, followed by `tail`: the whole of it must fit.
/// Empty when not even `tail` alone fits.
fn longest_prefix(text: &str, tail: &str, scale: u32, max_width: u32) -> String {
    let mut best = String::new();
    let mut cur = String::new();
    for ch in text.chars() {
        cur.push(ch);
        if text_width(&format!("{cur}{tail}"), scale) > max_width {
            break;
        }
        best.clone_from(&cur);
    }
    best
}

/// Splits `text` into lines at most `max_width` pixels wide at text scale
/// `scale` (a line holds at least one character, even if wider): at white
/// space, and inside a longer word after an underscore or, failing that,
/// anywhere (so that array names like `coaptation_distance_mm` break at
/// their parts). Words are joined by single spaces; empty text gives no
/// line.
pub fn wrap(text: &str, max_width: u32, scale: u32) -> Vec<String> {
    let fits = |s: &str| text_width(s, scale) <= max_width;
    let mut pieces: Vec<String> = Vec::new();
    for word in text.split_whitespace() {
        if fits(word) {
            pieces.push(word.to_string());
            continue;
        }
        let mut cur = String::new();
        for part in word.split_inclusive('_') {
            if !cur.is_empty() && !fits(&format!("{cur}{part}")) {
                pieces.push(std::mem::take(&mut cur));
            }
            cur.push_str(part);
            while !fits(&cur) && cur.chars().count() > 1 {
                let mut head = longest_prefix(&cur, "", scale, max_width);
                if head.is_empty() {
                    head = cur.chars().take(1).collect();
                }
                cur = cur[head.len()..].to_string();
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
            Some(l) if fits(&format!("{l} {p}")) => {
                l.push(' ');
                l.push_str(&p);
            }
            _ => lines.push(p),
        }
    }
    lines
}

/// The largest text scale `s`, `1 <= s <= max_scale`, at which `text` is at
/// most `max_width` pixels wide (`text_width(text, s) <= max_width`); 1
/// when it fits at none.
pub fn fit_scale(text: &str, max_scale: u32, max_width: u32) -> u32 {
    let mut scale = max_scale.max(1);
    while scale > 1 && text_width(text, scale) > max_width {
        scale -= 1;
    }
    scale
}

/// `text` fitted into `max_width` pixels: the scale of [`fit_scale`] and the
/// text itself, or, when it does not fit even at scale 1, its longest
/// prefix that fits followed by `...` (only the longest prefix that fits
/// when not even `...` does).
pub fn fit(text: &str, max_scale: u32, max_width: u32) -> (u32, String) {
    let scale = fit_scale(text, max_scale, max_width);
    if text_width(text, scale) <= max_width {
        return (scale, text.to_string());
    }
    let cut = if text_width(ELLIPSIS, scale) <= max_width {
        longest_prefix(text, ELLIPSIS, scale, max_width) + ELLIPSIS
    } else {
        longest_prefix(text, "", scale, max_width)
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
    let mut lines = wrap(subtitle, room, 1);
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
    use proptest::prelude::*;

    /// Width of `text` at scale 1.
    fn w(text: &str) -> u32 {
        text_width(text, 1)
    }

    #[test]
    fn wrap_splits_at_spaces() {
        let room = w("thickness");
        assert_eq!(
            wrap("wall thickness in mm", room, 1),
            vec!["wall", "thickness", "in mm"]
        );
        assert_eq!(wrap("", 10, 1), Vec::<String>::new());
        assert_eq!(wrap("  two   spaces ", 200, 1), vec!["two spaces"]);
    }

    #[test]
    fn wrap_breaks_long_words_after_underscores_then_anywhere() {
        let room = w("distance_mm");
        assert_eq!(
            wrap("coaptation_distance_mm of", room, 1),
            vec!["coaptation_", "distance_mm", "of"]
        );
        let room = w("abcd");
        let lines = wrap("abcdabcdab", room, 1);
        assert_eq!(lines, vec!["abcd", "abcd", "ab"]);
        // No room at all: one character a line.
        assert_eq!(wrap("ab c", 0, 1), vec!["a", "b", "c"]);
    }

    #[test]
    fn fit_takes_the_largest_scale_then_cuts() {
        assert_eq!(fit_scale("abcd", 2, text_width("abcd", 2)), 2);
        assert_eq!(fit_scale("abcd", 2, text_width("abcd", 2) - 1), 1);
        assert_eq!(fit_scale("abcd", 0, 8), 1);
        assert_eq!(fit("abcd", 2, w("abcd") + 1), (1, "abcd".to_string()));
        assert_eq!(fit("abcdefghij", 2, w("abc...")), (1, "abc...".to_string()));
        assert_eq!(fit("abcdefghij", 1, w("...") - 1), (1, "a".to_string()));
        assert_eq!(fit("abcdefghij", 1, 0), (1, String::new()));
    }

    #[test]
    fn a_title_band_drops_what_does_not_fit_with_an_ellipsis() {
        let style = TitleStyle {
            title_top: 0,
            margin: 0,
            subtitle_top: 26,
            line_step: 14,
            subtitle_lines: 1,
            subtitle_ink: INK,
        };
        // "one two" fits, "one two three" does not: "one two..." is drawn.
        let width = w("one two...") + 2;
        let mut img = Image::new(width, 40, PAPER).unwrap();
        title_band(&mut img, &style, "T", 2, "one two three").unwrap();
        let mut expect = Image::new(width, 40, PAPER).unwrap();
        expect
            .draw_text((width / 2) as i32, 26, "one two...", 1, INK, Anchor::Center)
            .unwrap();
        let rows = |im: &Image| -> Vec<Option<Rgba>> {
            (24..40)
                .flat_map(|y| (0..width).map(move |x| (x, y)))
                .map(|(x, y)| im.get(i64::from(x), y))
                .collect()
        };
        assert_eq!(rows(&img), rows(&expect));
        let both = text_width("abcd", 2);
        assert_eq!(style.shared_scale(both, &["abcd", "abc"], 2), 2);
        assert_eq!(style.shared_scale(both, &["abcd", "abcdef"], 2), 1);
    }

    proptest! {
        /// Every wrapped line fits (or is a single character), and the
        /// lines hold the words of the text in order.
        #[test]
        fn wrapped_lines_fit_and_keep_the_words(
            words in prop::collection::vec("[a-z_]{1,14}", 0..8),
            room in 0u32..160,
            scale in 1u32..3,
        ) {
            let text = words.join(" ");
            let lines = wrap(&text, room, scale);
            for l in &lines {
                prop_assert!(text_width(l, scale) <= room || l.chars().count() == 1, "{:?}", l);
            }
            let joined: String = lines.concat().chars().filter(|c| *c != ' ').collect();
            let original: String = text.chars().filter(|c| *c != ' ').collect();
            prop_assert_eq!(joined, original);
        }

        /// A fitted line is at most the room wide (at scale 1 when it had
        /// to be cut), and what was kept is a prefix of the text.
        #[test]
        fn fitted_text_fits(text in "[ -~]{0,30}", room in 0u32..200, max_scale in 1u32..4) {
            let (scale, shown) = fit(&text, max_scale, room);
            prop_assert!(text_width(&shown, scale) <= room);
            let kept = shown.strip_suffix(ELLIPSIS).unwrap_or(&shown);
            prop_assert!(text.starts_with(kept));
        }
    }
}
