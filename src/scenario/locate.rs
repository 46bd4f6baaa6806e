//! Where each value of a RON document starts, by path (`robots[3].radius`), so errors found
//! after parsing (duplicate ids, overlaps, out-of-range numbers) can name `FILE:LINE:COL`.
//!
//! ron reports positions for syntax and type errors but its values carry no spans, so this is
//! a small tokenizer and walker over the same text. It only runs on documents ron already
//! accepted, so it may give up quietly on anything unusual: a missing path just means the
//! error is reported without a position.

use std::collections::HashMap;

/// A 1-based line and column (in characters).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Pos {
    pub line: usize,
    pub col: usize,
}

#[derive(Clone, Debug, PartialEq)]
enum Tok {
    Ident(String),
    Scalar,
    Punct(char),
}

fn tokenize(src: &str) -> Vec<(Tok, Pos)> {
    let chars: Vec<char> = src.chars().collect();
    let mut out = Vec::new();
    let (mut i, mut line, mut col) = (0usize, 1usize, 1usize);
    let advance = |i: &mut usize, line: &mut usize, col: &mut usize, chars: &[char]| {
        if chars[*i] == '\n' {
            *line += 1;
            *col = 1;
        } else {
            *col += 1;
        }
        *i += 1;
    };
    while i < chars.len() {
        let c = chars[i];
        let pos = Pos { line, col };
        if c.is_whitespace() {
            advance(&mut i, &mut line, &mut col, &chars);
        } else if c == '/' && chars.get(i + 1) == Some(&'/') {
            while i < chars.len() && chars[i] != '\n' {
                advance(&mut i, &mut line, &mut col, &chars);
            }
        } else if c == '/' && chars.get(i + 1) == Some(&'*') {
            let mut depth = 0;
            while i < chars.len() {
                if chars[i] == '/' && chars.get(i + 1) == Some(&'*') {
                    depth += 1;
                    advance(&mut i, &mut line, &mut col, &chars);
                } else if chars[i] == '*' && chars.get(i + 1) == Some(&'/') {
                    depth -= 1;
                    advance(&mut i, &mut line, &mut col, &chars);
                    if depth == 0 {
                        advance(&mut i, &mut line, &mut col, &chars);
                        break;
                    }
                }
                advance(&mut i, &mut line, &mut col, &chars);
            }
        } else if c == '"' || c == '\'' {
            advance(&mut i, &mut line, &mut col, &chars);
            while i < chars.len() && chars[i] != c {
                if chars[i] == '\\' {
                    advance(&mut i, &mut line, &mut col, &chars);
                }
                if i < chars.len() {
                    advance(&mut i, &mut line, &mut col, &chars);
                }
            }
            if i < chars.len() {
                advance(&mut i, &mut line, &mut col, &chars);
            }
            out.push((Tok::Scalar, pos));
        } else if c == 'r' && matches!(chars.get(i + 1), Some('"') | Some('#')) {
            // Raw string r#"..."#.
            advance(&mut i, &mut line, &mut col, &chars);
            let mut hashes = 0;
            while i < chars.len() && chars[i] == '#' {
                hashes += 1;
                advance(&mut i, &mut line, &mut col, &chars);
            }
            advance(&mut i, &mut line, &mut col, &chars);
            'raw: while i < chars.len() {
                if chars[i] == '"' && (1..=hashes).all(|k| chars.get(i + k) == Some(&'#')) {
                    for _ in 0..=hashes {
                        advance(&mut i, &mut line, &mut col, &chars);
                    }
                    break 'raw;
                }
                advance(&mut i, &mut line, &mut col, &chars);
            }
            out.push((Tok::Scalar, pos));
        } else if c.is_ascii_digit() || ((c == '-' || c == '+' || c == '.') && i + 1 < chars.len())
        {
            // Numbers, and signed special floats like -inf.
            let start = i;
            advance(&mut i, &mut line, &mut col, &chars);
            while i < chars.len()
                && (chars[i].is_alphanumeric() || matches!(chars[i], '.' | '_' | '+' | '-'))
            {
                let prev = chars[i - 1];
                if matches!(chars[i], '+' | '-') && !matches!(prev, 'e' | 'E') {
                    break;
                }
                advance(&mut i, &mut line, &mut col, &chars);
            }
            let _ = start;
            out.push((Tok::Scalar, pos));
        } else if c.is_alphabetic() || c == '_' {
            let mut s = String::new();
            while i < chars.len() && (chars[i].is_alphanumeric() || chars[i] == '_') {
                s.push(chars[i]);
                advance(&mut i, &mut line, &mut col, &chars);
            }
            out.push((Tok::Ident(s), pos));
        } else {
            if c == '#' && chars.get(i + 1) == Some(&'!') {
                // An attribute like #![enable(...)]: skip to the end of the line.
                while i < chars.len() && chars[i] != '\n' {
                    advance(&mut i, &mut line, &mut col, &chars);
                }
                continue;
            }
            out.push((Tok::Punct(c), pos));
            advance(&mut i, &mut line, &mut col, &chars);
        }
    }
    out
}

/// `path.name`, or `name` at the root.
fn join(path: &str, name: &str) -> String {
    if path.is_empty() {
        name.to_string()
    } else {
        format!("{path}.{name}")
    }
}

struct Walker<'a> {
    toks: &'a [(Tok, Pos)],
    i: usize,
    out: HashMap<String, Pos>,
}

impl Walker<'_> {
    fn peek(&self, k: usize) -> Option<&Tok> {
        self.toks.get(self.i + k).map(|t| &t.0)
    }

    fn eat(&mut self, c: char) -> bool {
        if self.peek(0) == Some(&Tok::Punct(c)) {
            self.i += 1;
            true
        } else {
            false
        }
    }

    fn value(&mut self, path: &str) -> Option<()> {
        let (tok, pos) = self.toks.get(self.i)?.clone();
        self.out.entry(path.to_string()).or_insert(pos);
        match tok {
            Tok::Ident(_) => {
                self.i += 1;
                if self.eat('(') {
                    self.parens(path)?;
                }
            }
            Tok::Scalar => self.i += 1,
            Tok::Punct('(') => {
                self.i += 1;
                self.parens(path)?;
            }
            Tok::Punct('[') => {
                self.i += 1;
                let mut k = 0;
                while !self.eat(']') {
                    self.value(&format!("{path}[{k}]"))?;
                    k += 1;
                    self.eat(',');
                }
            }
            Tok::Punct('{') => {
                self.i += 1;
                while !self.eat('}') {
                    let key = match self.peek(0)? {
                        Tok::Ident(s) => s.clone(),
                        _ => String::new(),
                    };
                    self.value(&format!("{path}{{}}"))?;
                    if !self.eat(':') {
                        return None;
                    }
                    self.value(&join(path, &key))?;
                    self.eat(',');
                }
            }
            _ => return None,
        }
        Some(())
    }

    /// After an opening parenthesis: struct fields (`name: value`) or tuple elements.
    fn parens(&mut self, path: &str) -> Option<()> {
        let named =
            matches!(self.peek(0), Some(Tok::Ident(_))) && self.peek(1) == Some(&Tok::Punct(':'));
        let mut k = 0;
        while !self.eat(')') {
            if named {
                let Some(Tok::Ident(name)) = self.peek(0).cloned() else {
                    return None;
                };
                self.i += 2;
                self.value(&join(path, &name))?;
            } else {
                self.value(&format!("{path}[{k}]"))?;
                k += 1;
            }
            self.eat(',');
        }
        Some(())
    }
}

/// Maps each value's path to where it starts. The root is `""`; fields append `.name`,
/// positional elements `[k]` (so `Script([..])`'s steps are `algorithm[0][k]`).
pub fn locate(src: &str) -> HashMap<String, Pos> {
    let toks = tokenize(src);
    let mut w = Walker {
        toks: &toks,
        i: 0,
        out: HashMap::new(),
    };
    let _ = w.value("");
    w.out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paths_point_at_values() {
        let src = "Scenario(\n  name: \"a(b)\", // c: (\n  robots: [\n    Robot(id: 0, at: (1.0, -2.5), algorithm: Script([Wait(2.0), Turn(angle: -90.0)])),\n  ],\n)";
        let m = locate(src);
        assert_eq!(m["robots[0].id"], Pos { line: 4, col: 15 });
        assert_eq!(m["robots[0].at[1]"], Pos { line: 4, col: 28 });
        assert_eq!(
            m["robots[0].algorithm[0][1].angle"],
            Pos { line: 4, col: 77 }
        );
        assert_eq!(m["name"], Pos { line: 2, col: 9 });
    }
}
