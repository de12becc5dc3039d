//! Short, escaped quotes of input text for error messages. File contents are never echoed
//! verbatim: a message quotes at most [`EXCERPT_CHARS`] characters of the offending token,
//! with control characters (terminal escape sequences included) escaped, so that neither a
//! secret file nor a hostile one can be printed to the terminal through an error.

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

/// A parser's message with every control character escaped (`\n`, `\u{1b}`) and cut to
/// [`MESSAGE_CHARS`] characters, for messages that may quote input text.
pub fn sanitize_message(message: &str) -> String {
    let mut out = String::new();
    let mut written = 0;
    for c in message.chars() {
        let piece: String = if c.is_control() {
            c.escape_default().collect()
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
}
