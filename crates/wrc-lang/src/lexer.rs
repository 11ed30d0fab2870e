//! The lexer: source text to tokens with line and column, one `Newline` token per line end.
//! Keywords are recognised case-insensitively by the parser; the lexer only splits.

use crate::diagnostic::{Diagnostic, Span};

/// What a token is.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Tok {
    /// A name: letters, digits and `_`, starting with a letter or `_`, and an optional `$`
    /// at its end (`ERRMSG$`, `NAME$`: a string, by the BASIC convention).
    Ident,
    /// A number literal.
    Number(f64),
    /// A string literal, quotes removed and `""` turned into `"`.
    Str(String),
    LParen,
    RParen,
    LBracket,
    RBracket,
    Comma,
    Dot,
    Plus,
    Minus,
    Star,
    Slash,
    Eq,
    Ne,
    Lt,
    Le,
    Gt,
    Ge,
    /// The end of a line.
    Newline,
    /// The end of the source (always the last token).
    Eof,
}

/// A token, where it is and its text's byte range in the source.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Token {
    pub tok: Tok,
    pub span: Span,
    pub start: usize,
    pub end: usize,
}

/// Split `source` into tokens. Bad characters, unterminated strings and numbers that are too
/// large become diagnostics and are skipped; the token list always ends with `Newline`, `Eof`.
pub(crate) fn lex(source: &str, file: u16, diags: &mut Vec<Diagnostic>) -> Vec<Token> {
    let mut lexer = Lexer {
        file,
        src: source,
        bytes: source.as_bytes(),
        pos: 0,
        line: 1,
        col: 1,
        tokens: Vec::with_capacity(source.len() / 3 + 2),
    };
    lexer.run(diags);
    lexer.tokens
}

struct Lexer<'a> {
    file: u16,
    src: &'a str,
    bytes: &'a [u8],
    pos: usize,
    line: u32,
    col: u32,
    tokens: Vec<Token>,
}

impl Lexer<'_> {
    fn push(&mut self, tok: Tok, start: usize, col: u32, len: u32) {
        self.tokens.push(Token {
            tok,
            span: Span {
                line: self.line,
                col,
                len,
                file: self.file,
            },
            start,
            end: self.pos,
        });
    }

    /// Advance over one character, keeping the column in characters.
    fn bump(&mut self) {
        if let Some(c) = self.src[self.pos..].chars().next() {
            self.pos += c.len_utf8();
            self.col += 1;
        }
    }

    fn peek(&self) -> u8 {
        self.bytes.get(self.pos).copied().unwrap_or(0)
    }

    fn peek2(&self) -> u8 {
        self.bytes.get(self.pos + 1).copied().unwrap_or(0)
    }

    fn run(&mut self, diags: &mut Vec<Diagnostic>) {
        while self.pos < self.bytes.len() {
            let start = self.pos;
            let col = self.col;
            let b = self.peek();
            match b {
                b'\n' => {
                    self.pos += 1;
                    self.push(Tok::Newline, start, col, 1);
                    self.line += 1;
                    self.col = 1;
                }
                b' ' | b'\t' | b'\r' => self.bump(),
                b'\'' => {
                    while self.pos < self.bytes.len() && self.peek() != b'\n' {
                        self.bump();
                    }
                }
                b'0'..=b'9' => self.number(start, col, diags),
                b'.' if self.peek2().is_ascii_digit() => self.number(start, col, diags),
                b'"' => self.string(start, col, diags),
                b if b.is_ascii_alphabetic() || b == b'_' => {
                    while self.peek().is_ascii_alphanumeric() || self.peek() == b'_' {
                        self.pos += 1;
                        self.col += 1;
                    }
                    if self.peek() == b'$' {
                        self.pos += 1;
                        self.col += 1;
                    }
                    self.push(Tok::Ident, start, col, self.col - col);
                }
                _ => {
                    let (tok, width) = match (b, self.peek2()) {
                        (b'<', b'>') => (Some(Tok::Ne), 2),
                        (b'<', b'=') => (Some(Tok::Le), 2),
                        (b'>', b'=') => (Some(Tok::Ge), 2),
                        (b'<', _) => (Some(Tok::Lt), 1),
                        (b'>', _) => (Some(Tok::Gt), 1),
                        (b'=', _) => (Some(Tok::Eq), 1),
                        (b'(', _) => (Some(Tok::LParen), 1),
                        (b')', _) => (Some(Tok::RParen), 1),
                        (b'[', _) => (Some(Tok::LBracket), 1),
                        (b']', _) => (Some(Tok::RBracket), 1),
                        (b',', _) => (Some(Tok::Comma), 1),
                        (b'.', _) => (Some(Tok::Dot), 1),
                        (b'+', _) => (Some(Tok::Plus), 1),
                        (b'-', _) => (Some(Tok::Minus), 1),
                        (b'*', _) => (Some(Tok::Star), 1),
                        (b'/', _) => (Some(Tok::Slash), 1),
                        _ => (None, 1),
                    };
                    match tok {
                        Some(tok) => {
                            self.pos += width;
                            self.col += width as u32;
                            self.push(tok, start, col, width as u32);
                        }
                        None => {
                            self.bump();
                            let c = self.src[start..self.pos].chars().next().unwrap_or('?');
                            let span = Span {
                                line: self.line,
                                col,
                                len: 1,
                                file: self.file,
                            };
                            let message = if c == ';' || c == ':' {
                                format!("unexpected '{c}': write one statement per line, and separate PRINT items with ','")
                            } else {
                                format!("unexpected character {c:?}")
                            };
                            diags.push(Diagnostic::error(span, message));
                        }
                    }
                }
            }
        }
        let col = self.col;
        let end = self.pos;
        if self.tokens.last().is_none_or(|t| t.tok != Tok::Newline) {
            self.push(Tok::Newline, end, col, 1);
        }
        self.push(Tok::Eof, end, col, 1);
    }

    fn number(&mut self, start: usize, col: u32, diags: &mut Vec<Diagnostic>) {
        while self.peek().is_ascii_digit() {
            self.bump();
        }
        if self.peek() == b'.' && self.peek2().is_ascii_digit() {
            self.bump();
            while self.peek().is_ascii_digit() {
                self.bump();
            }
        } else if self.peek() == b'.' && !self.peek2().is_ascii_alphabetic() {
            // "1." is 1.0; "P1.X" never gets here (P1 is a name).
            self.bump();
        }
        if matches!(self.peek(), b'e' | b'E') {
            let save = (self.pos, self.col);
            self.bump();
            if matches!(self.peek(), b'+' | b'-') {
                self.bump();
            }
            if self.peek().is_ascii_digit() {
                while self.peek().is_ascii_digit() {
                    self.bump();
                }
            } else {
                (self.pos, self.col) = save;
            }
        }
        let text = &self.src[start..self.pos];
        let span = Span {
            line: self.line,
            col,
            len: self.col - col,
            file: self.file,
        };
        match text.parse::<f64>() {
            Ok(v) if v.is_finite() => self.push(Tok::Number(v), start, col, self.col - col),
            _ => {
                diags.push(Diagnostic::error(
                    span,
                    format!("number {text} is too large (at most about 1.8e308)"),
                ));
                self.push(Tok::Number(0.0), start, col, self.col - col);
            }
        }
    }

    fn string(&mut self, start: usize, col: u32, diags: &mut Vec<Diagnostic>) {
        self.bump();
        let mut text = String::new();
        loop {
            match self.peek() {
                b'"' if self.peek2() == b'"' => {
                    text.push('"');
                    self.bump();
                    self.bump();
                }
                b'"' => {
                    self.bump();
                    break;
                }
                b'\n' | 0 if self.pos >= self.bytes.len() || self.peek() == b'\n' => {
                    let span = Span {
                        line: self.line,
                        col,
                        len: self.col - col,
                        file: self.file,
                    };
                    diags.push(Diagnostic::error(
                        span,
                        "string not closed: add '\"' before the end of the line",
                    ));
                    break;
                }
                _ => {
                    let at = self.pos;
                    self.bump();
                    text.push_str(&self.src[at..self.pos]);
                }
            }
        }
        self.push(Tok::Str(text), start, col, self.col - col);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn kinds(src: &str) -> Vec<Tok> {
        let mut d = Vec::new();
        lex(src, 0, &mut d).into_iter().map(|t| t.tok).collect()
    }

    #[test]
    fn splits_operators_numbers_names_and_comments() {
        assert_eq!(
            kinds("X = P1.X <> 1.5e2 ' comment\n"),
            vec![
                Tok::Ident,
                Tok::Eq,
                Tok::Ident,
                Tok::Dot,
                Tok::Ident,
                Tok::Ne,
                Tok::Number(150.0),
                Tok::Newline,
                Tok::Eof
            ]
        );
    }

    #[test]
    fn strings_double_their_quotes_and_report_a_missing_end() {
        assert_eq!(
            kinds("\"a\"\"b\""),
            vec![Tok::Str("a\"b".into()), Tok::Newline, Tok::Eof]
        );
        let mut d = Vec::new();
        lex("PRINT \"open\nX", 0, &mut d);
        assert_eq!(d.len(), 1);
        assert_eq!((d[0].line, d[0].col), (1, 7));
    }

    #[test]
    fn columns_count_characters() {
        let mut d = Vec::new();
        let t = lex("\"é\" X", 0, &mut d);
        assert_eq!(t[1].span.col, 5);
    }
}
