//! Short, escaped quotes of input text for error messages, and the escaping of control
//! characters in any text shown to a user. File contents are never echoed verbatim: a
//! message quotes at most [`EXCERPT_CHARS`] characters of the offending token, with control
//! characters (terminal escape sequences included) escaped, so that neither a secret file
//! nor a hostile one can be printed to the terminal through an error; and text taken
//! whole from an input (a model's name, a path) goes through [`escape_controls`] before it
//! reaches a terminal, a CSV comment or a plot.

use std::borrow::Cow;

/// Most characters of model-file text (a key, a kind, a path) that an error message quotes.
pub const EXCERPT_CHARS: usize = 40;

/// Most characters of a data file's token (a Matrix Market entry, a coordinate) that an
/// error message quotes: shorter, because a data file may be one the user did not write
/// (`--allow-outside-paths`), and a message must not reveal a line of it.
pub const DATA_EXCERPT_CHARS: usize = 16;

/// Most characters of a message produced by a parser (TOML, serde) that may contain input
/// text; longer messages are cut.
pub const MESSAGE_CHARS: usize = 240;

/// `token` quoted for a message: at most [`EXCERPT_CHARS`] characters, in double quotes,
/// escaped like a Rust string literal (`"\u{1b}[31m"`), with `…` after the quote when the
/// token was cut.
pub fn excerpt(token: &str) -> String {
    excerpt_of(token, EXCERPT_CHARS)
}

/// A data file's `token` quoted for a message like [`excerpt`], at most
/// [`DATA_EXCERPT_CHARS`] characters.
pub fn data_excerpt(token: &str) -> String {
    excerpt_of(token, DATA_EXCERPT_CHARS)
}

fn excerpt_of(token: &str, max_chars: usize) -> String {
    let mut chars = token.chars();
    let head: String = chars.by_ref().take(max_chars).collect();
    let cut = if chars.next().is_some() { "…" } else { "" };
    format!("{head:?}{cut}")
}

/// Which line breaks [`escape_controls`] keeps.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LineBreaks {
    /// Every control character is escaped, `\n` and `\t` too: for one-line texts (a
    /// model's name, a path, a title, a CSV comment).
    Escape,
    /// `\n` and `\t` pass, every other control character is escaped: for a text of several
    /// lines written as a whole (a report on a terminal, a CSV file).
    Keep,
}

/// `text` with every control character — C0 (below U+0020), DEL (U+007F) and C1
/// (U+0080–U+009F), except `\n` and `\t` when `line_breaks` is [`LineBreaks::Keep`] —
/// replaced by a visible escape (`\u{1b}`, `\r`, `\n`), so that terminal escape sequences
/// in input text cannot act on a terminal. Borrowed when nothing needs escaping.
pub fn escape_controls(text: &str, line_breaks: LineBreaks) -> Cow<'_, str> {
    let escaped =
        |c: char| c.is_control() && !(line_breaks == LineBreaks::Keep && (c == '\n' || c == '\t'));
    if !text.chars().any(escaped) {
        return Cow::Borrowed(text);
    }
    let mut out = String::with_capacity(text.len() + 8);
    for c in text.chars() {
        if escaped(c) {
            out.extend(c.escape_default());
        } else {
            out.push(c);
        }
    }
    Cow::Owned(out)
}

/// A parser's message with every control character escaped (`\n`, `\u{1b}`) and cut to
/// [`MESSAGE_CHARS`] characters, for messages that may quote input text.
pub fn sanitize_message(message: &str) -> String {
    let mut out = String::new();
    let mut written = 0;
    for c in message.chars() {
        let piece: String = if c.is_control() {
            escape_controls(c.encode_utf8(&mut [0; 4]), LineBreaks::Escape).into_owned()
        } else {
            c.to_string()
        };
        written += piece.chars().count();
        if written > MESSAGE_CHARS {
            out.push('…');
            break;
        }
        out.push_str(&piece);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn excerpts_are_short_and_escaped() {
        assert_eq!(excerpt("abc"), "\"abc\"");
        let hostile = "\u{1b}[31mred\u{7}";
        let q = excerpt(hostile);
        assert!(!q.chars().any(char::is_control), "{q}");
        assert!(q.contains("\\u{1b}[31mred"), "{q}");
        let long = "x".repeat(1000);
        let q = excerpt(&long);
        assert_eq!(q.chars().filter(|&c| c == 'x').count(), EXCERPT_CHARS);
        assert!(q.ends_with('…'), "{q}");
        let q = data_excerpt("root:x:0:0:root:/root:/bin/bash");
        assert_eq!(q, "\"root:x:0:0:root:\"…");
        let m = sanitize_message(&format!("bad \u{1b}]0;title\u{7} {}", "y".repeat(1000)));
        assert!(!m.chars().any(char::is_control), "{m}");
        assert!(m.chars().count() <= MESSAGE_CHARS + 1, "{}", m.len());
    }

    #[test]
    fn every_control_character_is_escaped_visibly() {
        let hostile = "a\u{1b}[2J\u{1b}]0;pwned\u{7}\u{7f}\u{9b}b\r\n\tc";
        let e = escape_controls(hostile, LineBreaks::Escape);
        assert_eq!(
            e,
            "a\\u{1b}[2J\\u{1b}]0;pwned\\u{7}\\u{7f}\\u{9b}b\\r\\n\\tc"
        );
        let k = escape_controls(hostile, LineBreaks::Keep);
        assert!(k.ends_with("b\\r\n\tc"), "{k}");
        assert!(!k.chars().any(|c| c.is_control() && c != '\n' && c != '\t'));
        // plain text (non-ASCII included) is borrowed unchanged
        assert!(matches!(
            escape_controls("Stab — 30 kHz, µm", LineBreaks::Escape),
            Cow::Borrowed("Stab — 30 kHz, µm")
        ));
    }
}
