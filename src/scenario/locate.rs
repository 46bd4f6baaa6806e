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

/// Tokens with where they start and their char range.
fn tokenize(src: &str) -> Vec<(Tok, Pos, std::ops::Range<usize>)> {
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
        let at = i;
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
            out.push((Tok::Scalar, pos, at..i));
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
            out.push((Tok::Scalar, pos, at..i));
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
            out.push((Tok::Scalar, pos, at..i));
        } else if c.is_alphabetic() || c == '_' {
            let mut s = String::new();
            while i < chars.len() && (chars[i].is_alphanumeric() || chars[i] == '_') {
                s.push(chars[i]);
                advance(&mut i, &mut line, &mut col, &chars);
            }
            out.push((Tok::Ident(s), pos, at..i));
        } else {
            if c == '#' && chars.get(i + 1) == Some(&'!') {
                // An attribute like #![enable(...)]: skip to the end of the line.
                while i < chars.len() && chars[i] != '\n' {
                    advance(&mut i, &mut line, &mut col, &chars);
                }
                continue;
            }
            advance(&mut i, &mut line, &mut col, &chars);
            out.push((Tok::Punct(c), pos, at..i));
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

struct Walker {
    toks: Vec<(Tok, Pos, std::ops::Range<usize>)>,
    chars: Vec<char>,
    i: usize,
    out: HashMap<String, Pos>,
    /// Each value's char range, by path.
    spans: HashMap<String, std::ops::Range<usize>>,
    /// Map keys in the order written: (the map's path, the key, where it starts).
    keys: Vec<(String, String, Pos)>,
}

impl Walker {
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
        let (tok, pos, range) = self.toks.get(self.i)?.clone();
        self.out.entry(path.to_string()).or_insert(pos);
        self.one(path, tok)?;
        let end = self.toks[self.i - 1].2.end;
        self.spans
            .entry(path.to_string())
            .or_insert(range.start..end);
        Some(())
    }

    fn one(&mut self, path: &str, tok: Tok) -> Option<()> {
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
                        // A string key, unquoted (no escapes: a path or a name).
                        Tok::Scalar => {
                            let r = self.toks[self.i].2.clone();
                            let text: String = self.chars[r].iter().collect();
                            text.trim_matches('"').to_string()
                        }
                        _ => String::new(),
                    };
                    let at = self.toks[self.i].1;
                    self.keys.push((path.to_string(), key.clone(), at));
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
    walk(src).out
}

fn walk(src: &str) -> Walker {
    let mut w = Walker {
        toks: tokenize(src),
        chars: src.chars().collect(),
        i: 0,
        out: HashMap::new(),
        spans: HashMap::new(),
        keys: Vec::new(),
    };
    let _ = w.value("");
    w
}

/// A RON document's values by path: where each starts and its byte range, and the keys of
/// its maps in the order written.
#[derive(Clone, Debug, Default)]
pub struct Spans {
    pub starts: HashMap<String, Pos>,
    pub ranges: HashMap<String, std::ops::Range<usize>>,
    /// `(map path, key, where the key starts)`, in the document's order.
    pub keys: Vec<(String, String, Pos)>,
}

/// [`locate`] with byte ranges and map keys.
pub fn spans(src: &str) -> Spans {
    let w = walk(src);
    // Char index -> byte offset.
    let mut bytes: Vec<usize> = src.char_indices().map(|(b, _)| b).collect();
    bytes.push(src.len());
    Spans {
        starts: w.out,
        ranges: w
            .spans
            .into_iter()
            .map(|(k, r)| (k, bytes[r.start]..bytes[r.end]))
            .collect(),
        keys: w.keys,
    }
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
        let s = spans(src);
        assert_eq!(&src[s.ranges["robots[0].at"].clone()], "(1.0, -2.5)");
        assert_eq!(
            &src[s.ranges["robots[0].algorithm"].clone()],
            "Script([Wait(2.0), Turn(angle: -90.0)])"
        );
        assert_eq!(&src[s.ranges["name"].clone()], "\"a(b)\"");
    }

    #[test]
    fn string_keys_in_order() {
        let src = "S(axes: {\"b.c[0]\": [1, 2], \"a\": [Some(3)]})";
        let s = spans(src);
        let keys: Vec<(&str, &str, usize)> = s
            .keys
            .iter()
            .map(|(m, k, p)| (m.as_str(), k.as_str(), p.col))
            .collect();
        assert_eq!(keys, [("axes", "b.c[0]", 10), ("axes", "a", 28)]);
        assert_eq!(&src[s.ranges["axes.b.c[0][1]"].clone()], "2");
        assert_eq!(&src[s.ranges["axes.a[0]"].clone()], "Some(3)");
    }
}
