//! Regular expressions over Heckbert path strings (Heckbert 1990), e.g. `LS+DE` for caustics:
//! symbols `L D G S E`, `.` (any scattering vertex: D, G or S), classes `[DG]` and `[^S]` (a
//! complement among D, G, S), grouping `( )`, alternation `|` and the repetitions `*`, `+`, `?`.
//! An expression must match the whole path string, `L` to `E`.
//!
//! Compiled by Thompson's construction (Thompson 1968) to an NFA and by the subset construction
//! to a DFA, so matching a path is one table lookup per vertex.

use super::class::{MAX_RECORDED, PathClass};
use lightlab_materials::LobeClass;
use std::collections::HashMap;
use std::fmt;

/// Alphabet indices.
const L: usize = 0;
const D: usize = 1;
const G: usize = 2;
const S: usize = 3;
const E: usize = 4;
const SYMBOLS: usize = 5;
const SCATTER: u8 = (1 << D) | (1 << G) | (1 << S);
/// The DFA's dead state.
const DEAD: u32 = 0;

/// A malformed expression: where (1-based column, in characters) and what.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PathRegexError {
    /// The expression as written (its first 40 characters and "…" when it is over the length limit).
    pub expression: String,
    /// Column of the fault, from 1, in characters.
    pub column: usize,
    /// What is wrong there.
    pub message: String,
}

impl fmt::Display for PathRegexError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "path expression \"{}\", column {}: {}",
            self.expression, self.column, self.message
        )
    }
}

impl std::error::Error for PathRegexError {}

/// A compiled path expression.
#[derive(Clone, Debug)]
pub struct PathRegex {
    source: String,
    /// `next[state][symbol]`; state 0 is dead, state 1 the start.
    next: Vec<[u32; SYMBOLS]>,
    accept: Vec<bool>,
}

impl PartialEq for PathRegex {
    fn eq(&self, other: &Self) -> bool {
        self.source == other.source
    }
}

/// The longest expression accepted, in characters.
const MAX_EXPRESSION: usize = 1000;

/// The most DFA states an expression may compile to. Subset construction is exponential in the
/// worst case: `L.*D` followed by n single-symbol positions and `E` needs about 2ⁿ states (n = 20,
/// 25 characters, took 19 s and 621 MB); 2¹⁴ states is a 320 kB table, built in milliseconds,
/// far more than any class of the README needs.
const MAX_STATES: usize = 1 << 14;

enum Ast {
    Set(u8),
    Concat(Vec<Ast>),
    Alt(Vec<Ast>),
    Star(Box<Ast>),
    Plus(Box<Ast>),
    Opt(Box<Ast>),
}

struct Parser<'a> {
    chars: Vec<char>,
    pos: usize,
    source: &'a str,
}

impl Parser<'_> {
    fn error(&self, column: usize, message: impl Into<String>) -> PathRegexError {
        PathRegexError {
            expression: self.source.to_string(),
            column,
            message: message.into(),
        }
    }

    fn skip_space(&mut self) {
        while self.pos < self.chars.len() && self.chars[self.pos].is_whitespace() {
            self.pos += 1;
        }
    }

    fn peek(&mut self) -> Option<char> {
        self.skip_space();
        self.chars.get(self.pos).copied()
    }

    fn alt(&mut self) -> Result<Ast, PathRegexError> {
        let mut branches = vec![self.concat()?];
        while self.peek() == Some('|') {
            self.pos += 1;
            branches.push(self.concat()?);
        }
        Ok(if branches.len() == 1 {
            branches.pop().expect("one branch")
        } else {
            Ast::Alt(branches)
        })
    }

    fn concat(&mut self) -> Result<Ast, PathRegexError> {
        self.skip_space();
        let start = self.pos + 1;
        let mut items = Vec::new();
        while let Some(c) = self.peek() {
            if c == '|' || c == ')' {
                break;
            }
            items.push(self.repeat()?);
        }
        if items.is_empty() {
            return Err(self.error(start, "empty expression or alternative"));
        }
        Ok(Ast::Concat(items))
    }

    fn repeat(&mut self) -> Result<Ast, PathRegexError> {
        let mut a = self.atom()?;
        while let Some(c) = self.peek() {
            a = match c {
                '*' => Ast::Star(Box::new(a)),
                '+' => Ast::Plus(Box::new(a)),
                '?' => Ast::Opt(Box::new(a)),
                _ => break,
            };
            self.pos += 1;
        }
        Ok(a)
    }

    fn symbol(c: char) -> Option<u8> {
        Some(match c {
            'L' => 1 << L,
            'D' => 1 << D,
            'G' => 1 << G,
            'S' => 1 << S,
            'E' => 1 << E,
            _ => return None,
        })
    }

    fn atom(&mut self) -> Result<Ast, PathRegexError> {
        let c = self.peek().expect("atom called at a character");
        let column = self.pos + 1;
        self.pos += 1;
        match c {
            '.' => Ok(Ast::Set(SCATTER)),
            '(' => {
                let inner = self.alt()?;
                if self.peek() != Some(')') {
                    return Err(self.error(column, "unclosed '('"));
                }
                self.pos += 1;
                Ok(inner)
            }
            '[' => {
                let negate = self.peek() == Some('^');
                if negate {
                    self.pos += 1;
                }
                let mut set = 0u8;
                loop {
                    match self.peek() {
                        None => return Err(self.error(column, "unclosed '['")),
                        Some(']') => {
                            self.pos += 1;
                            break;
                        }
                        Some(s) => match Self::symbol(s) {
                            Some(bit) => {
                                set |= bit;
                                self.pos += 1;
                            }
                            None => {
                                return Err(self.error(
                                    self.pos + 1,
                                    format!("'{s}' is not a path symbol (L, D, G, S, E)"),
                                ));
                            }
                        },
                    }
                }
                if negate {
                    set = SCATTER & !set;
                }
                if set == 0 {
                    return Err(self.error(column, "empty class"));
                }
                Ok(Ast::Set(set))
            }
            '*' | '+' | '?' => Err(self.error(column, format!("'{c}' has nothing to repeat"))),
            ')' => Err(self.error(column, "unmatched ')'")),
            ']' => Err(self.error(column, "unmatched ']'")),
            _ => Self::symbol(c).map(Ast::Set).ok_or_else(|| {
                self.error(
                    column,
                    format!(
                        "'{c}' is not a path symbol: use L, D, G, S, E, '.', [..], (..), |, *, + or ?"
                    ),
                )
            }),
        }
    }
}

/// Thompson NFA: per state, ε-edges and at most one symbol-set edge.
#[derive(Default)]
struct Nfa {
    eps: Vec<Vec<usize>>,
    on: Vec<Option<(u8, usize)>>,
}

impl Nfa {
    fn state(&mut self) -> usize {
        self.eps.push(Vec::new());
        self.on.push(None);
        self.eps.len() - 1
    }

    /// Builds `a` and returns its (start, end) states.
    fn build(&mut self, a: &Ast) -> (usize, usize) {
        match a {
            Ast::Set(set) => {
                let (s, e) = (self.state(), self.state());
                self.on[s] = Some((*set, e));
                (s, e)
            }
            Ast::Concat(items) => {
                let mut frags = items.iter().map(|i| self.build(i)).collect::<Vec<_>>();
                for w in frags.windows(2) {
                    self.eps[w[0].1].push(w[1].0);
                }
                let first = frags.first().expect("non-empty").0;
                let last = frags.pop().expect("non-empty").1;
                (first, last)
            }
            Ast::Alt(branches) => {
                let (s, e) = (self.state(), self.state());
                for b in branches {
                    let (bs, be) = self.build(b);
                    self.eps[s].push(bs);
                    self.eps[be].push(e);
                }
                (s, e)
            }
            Ast::Star(inner) | Ast::Plus(inner) | Ast::Opt(inner) => {
                let (is, ie) = self.build(inner);
                let (s, e) = (self.state(), self.state());
                self.eps[s].push(is);
                self.eps[ie].push(e);
                if !matches!(a, Ast::Plus(_)) {
                    self.eps[s].push(e);
                }
                if !matches!(a, Ast::Opt(_)) {
                    self.eps[ie].push(is);
                }
                (s, e)
            }
        }
    }

    fn closure(&self, set: &mut [bool]) {
        let mut stack: Vec<usize> = (0..set.len()).filter(|&i| set[i]).collect();
        while let Some(s) = stack.pop() {
            for &t in &self.eps[s] {
                if !set[t] {
                    set[t] = true;
                    stack.push(t);
                }
            }
        }
    }
}

impl PathRegex {
    /// Parses and compiles `expression`.
    pub fn new(expression: &str) -> Result<PathRegex, PathRegexError> {
        // Parsing and compiling recurse per nesting level and take time quadratic in the length:
        // 20 000 nested parentheses overflowed the stack.
        let length = expression.chars().count();
        if length > MAX_EXPRESSION {
            return Err(PathRegexError {
                expression: expression.chars().take(40).chain("…".chars()).collect(),
                column: MAX_EXPRESSION + 1,
                message: format!(
                    "an expression is at most {MAX_EXPRESSION} characters long, this one {length}"
                ),
            });
        }
        let mut p = Parser {
            chars: expression.chars().collect(),
            pos: 0,
            source: expression,
        };
        let ast = p.alt()?;
        if let Some(c) = p.peek() {
            return Err(p.error(
                p.pos + 1,
                if c == ')' {
                    "unmatched ')'".to_string()
                } else {
                    format!("unexpected '{c}'")
                },
            ));
        }
        let mut nfa = Nfa::default();
        let (start, end) = nfa.build(&ast);
        // Subset construction.
        let n = nfa.eps.len();
        let mut first = vec![false; n];
        first[start] = true;
        nfa.closure(&mut first);
        let mut ids: HashMap<Vec<bool>, u32> = HashMap::new();
        let mut sets: Vec<Vec<bool>> = vec![vec![false; n], first.clone()];
        ids.insert(vec![false; n], DEAD);
        ids.insert(first, 1);
        let mut next: Vec<[u32; SYMBOLS]> = vec![[DEAD; SYMBOLS]; 2];
        let mut i = 1;
        while i < sets.len() {
            for sym in 0..SYMBOLS {
                let mut to = vec![false; n];
                for (s, &inside) in sets[i].iter().enumerate() {
                    if inside
                        && let Some((set, t)) = nfa.on[s]
                        && set & (1 << sym) != 0
                    {
                        to[t] = true;
                    }
                }
                nfa.closure(&mut to);
                let id = match ids.get(&to) {
                    Some(&id) => id,
                    None if sets.len() >= MAX_STATES => {
                        return Err(PathRegexError {
                            expression: expression.to_string(),
                            column: 1,
                            message: format!(
                                "compiles to more than {MAX_STATES} matching states: a run of \
                                 fixed positions after a repetition (as in L.*D......E) doubles \
                                 them with each position; shorten that run"
                            ),
                        });
                    }
                    None => {
                        let id = sets.len() as u32;
                        ids.insert(to.clone(), id);
                        sets.push(to);
                        next.push([DEAD; SYMBOLS]);
                        id
                    }
                };
                next[i][sym] = id;
            }
            i += 1;
        }
        let accept = sets.iter().map(|s| s[end]).collect();
        let re = PathRegex {
            source: expression.to_string(),
            next,
            accept,
        };
        if !re.matches_some_path() {
            return Err(PathRegexError {
                expression: expression.to_string(),
                column: 1,
                message: "matches no path: paths read L, then D, G or S per scattering vertex, then E (e.g. LD+E)".into(),
            });
        }
        Ok(re)
    }

    /// The expression as written (its first 40 characters and "…" when it is over the length limit).
    pub fn as_str(&self) -> &str {
        &self.source
    }

    /// Whether the language meets L[DGS]*E (a search over DFA states).
    fn matches_some_path(&self) -> bool {
        let mut seen = vec![false; self.next.len()];
        let mut stack = vec![self.next[1][L]];
        while let Some(s) = stack.pop() {
            if s == DEAD || seen[s as usize] {
                continue;
            }
            seen[s as usize] = true;
            if self.accept[self.next[s as usize][E] as usize] {
                return true;
            }
            stack.extend([D, G, S].map(|sym| self.next[s as usize][sym]));
        }
        false
    }

    /// The numbers of scattering vertices, from `min` to `max` (and at most [`MAX_RECORDED`],
    /// beyond which no path matches), of the paths the expression matches: the sets of DFA states
    /// reached after k of D, G or S, one k after the other.
    pub fn lengths(&self, min: u32, max: u32) -> Vec<u32> {
        let mut states = vec![self.next[1][L]];
        let mut lengths = Vec::new();
        for k in 0..=max.min(MAX_RECORDED) {
            if k >= min
                && states
                    .iter()
                    .any(|&s| self.accept[self.next[s as usize][E] as usize])
            {
                lengths.push(k);
            }
            let mut next: Vec<u32> = states
                .iter()
                .flat_map(|&s| [D, G, S].map(|sym| self.next[s as usize][sym]))
                .filter(|&s| s != DEAD)
                .collect();
            next.sort_unstable();
            next.dedup();
            states = next;
        }
        lengths
    }

    /// Whether the path `L class E` matches. Paths longer than the recorded vertices never do.
    #[inline]
    pub fn matches(&self, class: &PathClass) -> bool {
        if class.is_long() {
            return false;
        }
        let mut s = self.next[1][L];
        for i in 0..class.len() {
            if s == DEAD {
                return false;
            }
            let sym = match class.get(i) {
                LobeClass::Diffuse => D,
                LobeClass::Glossy => G,
                LobeClass::Specular => S,
            };
            s = self.next[s as usize][sym];
        }
        self.accept[self.next[s as usize][E] as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use LobeClass::*;

    fn class(s: &str) -> PathClass {
        assert!(s.starts_with('L') && s.ends_with('E'));
        s[1..s.len() - 1].chars().fold(PathClass::EMPTY, |c, ch| {
            c.push(match ch {
                'D' => Diffuse,
                'G' => Glossy,
                'S' => Specular,
                _ => panic!("{ch}"),
            })
        })
    }

    #[test]
    fn the_documented_examples_match_what_they_should() {
        let cases: [(&str, &[&str], &[&str]); 7] = [
            ("LE", &["LE"], &["LDE", "LSE"]),
            ("LDE", &["LDE"], &["LE", "LDDE", "LGE"]),
            ("LD+E", &["LDE", "LDDDE"], &["LE", "LDSE", "LSDE"]),
            (
                "LS+DE",
                &["LSDE", "LSSDE"],
                &["LDE", "LSDDE", "LSDSE", "LSSGE"],
            ),
            ("LS+DS+E", &["LSDSE", "LSSDSSE"], &["LSDE", "LDSE"]),
            ("L.*SDS.*E", &["LSDSE", "LDDSDSGE"], &["LSDDSE", "LDE"]),
            ("L(D|G)*E", &["LE", "LDGDE"], &["LSE", "LDSDE"]),
        ];
        for (expr, yes, no) in cases {
            let re = PathRegex::new(expr).unwrap_or_else(|e| panic!("{e}"));
            for s in yes {
                assert!(re.matches(&class(s)), "{expr} should match {s}");
            }
            for s in no {
                assert!(!re.matches(&class(s)), "{expr} should not match {s}");
            }
        }
        let re = PathRegex::new("L [^S]? E").unwrap();
        assert!(re.matches(&class("LDE")) && re.matches(&class("LE")));
        assert!(!re.matches(&class("LSE")));
    }

    #[test]
    fn malformed_expressions_name_the_column() {
        for (expr, column, words) in [
            ("LS+DE)", 6, "unmatched ')'"),
            ("L(SD", 2, "unclosed '('"),
            ("L*E", 0, ""),
            ("+LE", 1, "nothing to repeat"),
            ("LXE", 2, "'X' is not a path symbol"),
            ("L[]E", 2, "empty class"),
            ("L[DQ]E", 4, "'Q'"),
            ("L|", 3, "empty"),
            ("", 1, "empty"),
            ("SDE", 1, "matches no path"),
            (
                &format!("L{}D{}E", "(".repeat(20_000), ")".repeat(20_000)),
                1001,
                "at most 1000",
            ),
        ] {
            let r = PathRegex::new(expr);
            if column == 0 {
                assert!(r.is_ok(), "{expr} is valid");
                continue;
            }
            let e = r.expect_err(expr);
            assert_eq!(e.column, column, "{expr}: {e}");
            assert!(e.to_string().contains(words), "{expr}: {e}");
        }
    }

    #[test]
    fn long_paths_never_match() {
        let mut c = PathClass::EMPTY;
        for _ in 0..100 {
            c = c.push(Diffuse);
        }
        assert!(!PathRegex::new("L.*E").unwrap().matches(&c));
    }

    /// An expression whose automaton would grow exponentially is refused at once, not built.
    #[test]
    fn exponential_automata_are_refused() {
        let dots = |n: usize| format!("L.*D{}E", ".".repeat(n));
        assert!(PathRegex::new(&dots(8)).is_ok());
        let e = PathRegex::new(&dots(24)).unwrap_err();
        assert!(e.message.contains("matching states"), "{e}");
    }
}
