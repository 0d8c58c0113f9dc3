//! Text safe to print on a terminal.

/// `text` safe to print on a terminal: control characters (C0, DEL, C1:
/// ESC, BEL, OSC, ... as found in hostile files' names and tokens) shown as
/// `\u{1b}` escapes, so a file cannot retitle, recolour or ring the
/// terminal; newlines become spaces (messages are one line).
pub fn printable(text: &str) -> std::borrow::Cow<'_, str> {
    if !text.chars().any(char::is_control) {
        return std::borrow::Cow::Borrowed(text);
    }
    let mut out = String::with_capacity(text.len() + 8);
    for c in text.chars() {
        match c {
            '\n' | '\r' => out.push(' '),
            c if c.is_control() => out.push_str(&c.escape_unicode().to_string()),
            c => out.push(c),
        }
    }
    std::borrow::Cow::Owned(out)
}
