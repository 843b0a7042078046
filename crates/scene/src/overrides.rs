//! Overrides of scene values from the command line (`lightlab render --set camera.fov=60`), as
//! Mitsuba's `-D` sets a scene parameter: the value at a path in the RON text is replaced by new
//! RON text, and everything else stays as written, so errors still point at the file's own lines.
//!
//! A path is field names, map keys and list indices: `camera.fov`, `camera.resolution`,
//! `materials.white.albedo` (a field of the material's variant), `shapes[3].material`,
//! `lights[0].intensity`. A field that is not written in the file cannot be overridden (its default
//! applies); the error lists the fields that are.

/// `text` with the value at `path` replaced by `value`.
pub fn set_value(text: &str, path: &str, value: &str) -> Result<String, String> {
    let segments = parse_path(path)?;
    let mut scanner = Scanner {
        s: text.as_bytes(),
        i: 0,
        in_value: false,
    };
    scanner.skip();
    let (start, end) = scanner.find(&segments, path)?;
    Ok(format!(
        "{}{}{}",
        &text[..start],
        one_value(value)?,
        &text[end..]
    ))
}

/// `value` as exactly one RON value: pasted into the file, a second one (`60, up: (0, 0, 1)`) would
/// set a field the file never wrote, and a trailing comment would swallow the rest of the line.
fn one_value(value: &str) -> Result<&str, String> {
    let value = value.trim();
    let mut v = Scanner {
        s: value.as_bytes(),
        i: 0,
        in_value: true,
    };
    let (start, end) = v
        .value()
        .map_err(|e| format!("{value:?} is not a RON value: {e}"))?;
    if end < value.len() {
        return Err(format!(
            "{value:?} is more than one value: write a single RON value (a number, a string, or a \
             bracketed tuple, list or map), without comments after it"
        ));
    }
    Ok(&value[start..end])
}

/// Applies `KEY=VALUE` overrides in order.
pub fn apply_overrides(text: &str, overrides: &[String]) -> Result<String, String> {
    let mut text = text.to_string();
    for o in overrides {
        let (key, value) = o
            .split_once('=')
            .ok_or_else(|| format!("--set {o}: write PATH=VALUE, e.g. camera.fov=60"))?;
        text = set_value(&text, key.trim(), value)
            .map_err(|e| format!("--set {}: {e}", key.trim()))?;
    }
    Ok(text)
}

#[derive(Debug, PartialEq)]
enum Segment {
    Name(String),
    Index(usize),
}

fn parse_path(path: &str) -> Result<Vec<Segment>, String> {
    let mut out = Vec::new();
    for part in path.split('.') {
        let (name, mut rest) = match part.find('[') {
            Some(i) => (&part[..i], &part[i..]),
            None => (part, ""),
        };
        if !name.is_empty() {
            out.push(Segment::Name(name.to_string()));
        } else if rest.is_empty() {
            return Err(format!("empty component in path {path:?}"));
        }
        while let Some(r) = rest.strip_prefix('[') {
            let (index, tail) = r
                .split_once(']')
                .ok_or_else(|| format!("unclosed [ in path {path:?}"))?;
            out.push(Segment::Index(index.trim().parse().map_err(|_| {
                format!("{index:?} is not a list index in path {path:?}")
            })?));
            rest = tail;
        }
        if !rest.is_empty() {
            return Err(format!("unexpected {rest:?} in path {path:?}"));
        }
    }
    Ok(out)
}

struct Scanner<'a> {
    s: &'a [u8],
    i: usize,
    /// Scanning the `--set` value rather than the scene file (errors then point into the value).
    in_value: bool,
}

impl Scanner<'_> {
    fn peek(&self) -> Option<u8> {
        self.s.get(self.i).copied()
    }

    /// Skips whitespace and comments.
    fn skip(&mut self) {
        loop {
            match (self.peek(), self.s.get(self.i + 1)) {
                (Some(c), _) if c.is_ascii_whitespace() => self.i += 1,
                (Some(b'/'), Some(b'/')) => {
                    while self.peek().is_some_and(|c| c != b'\n') {
                        self.i += 1;
                    }
                }
                (Some(b'/'), Some(b'*')) => {
                    self.i += 2;
                    while self.i < self.s.len() && !self.s[self.i..].starts_with(b"*/") {
                        self.i += 1;
                    }
                    self.i = (self.i + 2).min(self.s.len());
                }
                _ => return,
            }
        }
    }

    fn err(&self, what: &str) -> String {
        let at = self.i.min(self.s.len());
        if self.in_value {
            return format!("{what} (at character {} of the value)", at + 1);
        }
        let line = self.s[..at].iter().filter(|&&c| c == b'\n').count() + 1;
        format!("{what} (at line {line} of the scene)")
    }

    fn expect(&mut self, c: u8) -> Result<(), String> {
        self.skip();
        if self.peek() == Some(c) {
            self.i += 1;
            Ok(())
        } else {
            Err(self.err(&format!("expected '{}'", c as char)))
        }
    }

    /// An identifier or number at the cursor (possibly empty).
    fn word(&mut self) -> &str {
        let start = self.i;
        while self
            .peek()
            .is_some_and(|c| c.is_ascii_alphanumeric() || b"_.+-".contains(&c))
        {
            self.i += 1;
        }
        std::str::from_utf8(&self.s[start..self.i]).unwrap_or("")
    }

    /// A string literal at the cursor, returned unescaped enough to compare keys.
    fn string(&mut self) -> Result<String, String> {
        let start = self.i;
        self.i += 1;
        while let Some(c) = self.peek() {
            self.i += 1;
            match c {
                b'\\' => self.i += 1,
                b'"' => {
                    return Ok(String::from_utf8_lossy(&self.s[start + 1..self.i - 1]).into());
                }
                _ => {}
            }
        }
        Err(self.err("unterminated string"))
    }

    /// Skips one value; returns its span.
    fn value(&mut self) -> Result<(usize, usize), String> {
        self.skip();
        let start = self.i;
        match self.peek() {
            Some(b'"') => {
                self.string()?;
            }
            Some(b'(') | Some(b'[') | Some(b'{') => self.group()?,
            Some(_) => {
                if self.word().is_empty() {
                    return Err(self.err("expected a value"));
                }
                // A variant's fields follow its name; anything else after the word (spaces, a
                // comment) is not part of the value.
                let after = self.i;
                self.skip();
                if self.peek() == Some(b'(') {
                    self.group()?;
                } else {
                    self.i = after;
                }
            }
            None => return Err(self.err("unexpected end of the scene")),
        }
        Ok((start, self.i))
    }

    /// Skips a bracketed group at the cursor.
    fn group(&mut self) -> Result<(), String> {
        let close = match self.peek() {
            Some(b'(') => b')',
            Some(b'[') => b']',
            _ => b'}',
        };
        self.i += 1;
        loop {
            self.skip();
            match self.peek() {
                Some(c) if c == close => {
                    self.i += 1;
                    return Ok(());
                }
                Some(b',') | Some(b':') => self.i += 1,
                Some(_) => {
                    self.value()?;
                }
                None => return Err(self.err("unclosed bracket")),
            }
        }
    }

    /// The span of the value at `path`, from the value at the cursor.
    fn find(&mut self, path: &[Segment], full: &str) -> Result<(usize, usize), String> {
        let Some((first, rest)) = path.split_first() else {
            return self.value();
        };
        self.skip();
        // A named struct or enum variant: skip its name.
        if self.peek().is_some_and(|c| c.is_ascii_alphabetic()) {
            self.word();
            self.skip();
        }
        match (first, self.peek()) {
            (Segment::Name(name), Some(b'(')) | (Segment::Name(name), Some(b'{')) => {
                let braces = self.peek() == Some(b'{');
                self.i += 1;
                let mut seen = Vec::new();
                loop {
                    self.skip();
                    match self.peek() {
                        Some(b')') | Some(b'}') | None => {
                            return Err(format!(
                                "no {name:?} written there (it has {}); a value not written in \
                                 the file keeps its default and cannot be overridden",
                                if seen.is_empty() {
                                    "nothing".to_string()
                                } else {
                                    seen.join(", ")
                                }
                            ));
                        }
                        Some(b',') => self.i += 1,
                        Some(b'"') if braces => {
                            let key = self.string()?;
                            self.expect(b':')?;
                            if &key == name {
                                return self.find(rest, full);
                            }
                            seen.push(key);
                            self.value()?;
                        }
                        Some(_) => {
                            let key = self.word().to_string();
                            self.skip();
                            if self.peek() == Some(b':') {
                                self.i += 1;
                                if &key == name {
                                    return self.find(rest, full);
                                }
                                seen.push(key);
                                self.value()?;
                            } else {
                                return Err(self.err(&format!(
                                    "{full}: {name:?} is looked up in a value without field names"
                                )));
                            }
                        }
                    }
                }
            }
            (Segment::Index(k), Some(b'[')) | (Segment::Index(k), Some(b'(')) => {
                self.i += 1;
                let mut n = 0;
                loop {
                    self.skip();
                    match self.peek() {
                        Some(b']') | Some(b')') | None => {
                            return Err(format!("index [{k}] is out of range: there are {n}"));
                        }
                        Some(b',') => self.i += 1,
                        Some(_) if n == *k => return self.find(rest, full),
                        Some(_) => {
                            self.value()?;
                            n += 1;
                        }
                    }
                }
            }
            (Segment::Name(name), _) => {
                Err(self.err(&format!("{name:?}: not a struct or map here")))
            }
            (Segment::Index(k), _) => Err(self.err(&format!("[{k}]: not a list here"))),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SCENE: &str = r#"// A test scene.
Scene(
    camera: Camera(eye: (0, 0, 3.9), target: (0, 0, 0), fov: 40, resolution: (256, 256)),
    materials: { "white": Diffuse(albedo: (0.7, 0.7, 0.7)), "glass": Dielectric(ior: 1.5) },
    shapes: [
        Shape(geometry: Sphere(center: (0, 0, 0), radius: 1), material: "white"), /* one */
        Shape(geometry: Quad(corner: (-1, -1, -1), edge1: (0, 0, 2), edge2: (2, 0, 0)), material: "glass"),
    ],
)"#;

    #[test]
    fn replaces_values_at_paths() {
        let t = set_value(SCENE, "camera.fov", "60").unwrap();
        assert!(t.contains("fov: 60, resolution: (256, 256)"), "{t}");
        let t = set_value(SCENE, "camera.resolution", "(32, 24)").unwrap();
        assert!(t.contains("resolution: (32, 24))"), "{t}");
        let t = set_value(SCENE, "materials.glass.ior", "1.33").unwrap();
        assert!(t.contains("Dielectric(ior: 1.33)"), "{t}");
        let t = set_value(SCENE, "materials.white", "Mirror(reflectance: (1, 1, 1))").unwrap();
        assert!(
            t.contains("\"white\": Mirror(reflectance: (1, 1, 1)),"),
            "{t}"
        );
        let t = set_value(SCENE, "shapes[1].material", "\"white\"").unwrap();
        assert!(t.contains("edge2: (2, 0, 0)), material: \"white\")"), "{t}");
        let t = set_value(SCENE, "shapes[0].geometry.radius", "2").unwrap();
        assert!(t.contains("radius: 2)"), "{t}");
        let t = apply_overrides(
            SCENE,
            &["camera.eye = (1, 2, 3)".into(), "camera.fov=10".into()],
        )
        .unwrap();
        assert!(t.contains("eye: (1, 2, 3)") && t.contains("fov: 10"), "{t}");
        // Everything else is untouched, line by line.
        assert_eq!(t.lines().count(), SCENE.lines().count());
    }

    /// VALUE is one RON value: a second value or a comment would have been pasted into the file.
    #[test]
    fn values_are_exactly_one_ron_value() {
        for value in ["60, up: (0, 0, 1)", "60 // x", "(1, 2) (3, 4)", "", "(1, 2"] {
            let e = set_value(SCENE, "camera.fov", value).unwrap_err();
            assert!(e.contains("value"), "{value}: {e}");
        }
        // A fault inside the value points into the value, not at a line of the scene.
        let e = set_value(SCENE, "camera.fov", "(1,2").unwrap_err();
        assert!(
            e.contains("at character 5 of the value") && !e.contains("scene"),
            "{e}"
        );
        let t = set_value(SCENE, "camera.eye", " (1, /* up */ 2, 3) ").unwrap();
        assert!(t.contains("eye: (1, /* up */ 2, 3),"), "{t}");
    }

    #[test]
    fn bad_paths_say_what_is_there() {
        let e = set_value(SCENE, "camera.fovy", "1").unwrap_err();
        assert!(
            e.contains("\"fovy\"") && e.contains("eye, target, fov, resolution"),
            "{e}"
        );
        let e = set_value(SCENE, "shapes[2].material", "\"x\"").unwrap_err();
        assert!(
            e.contains("out of range") && e.contains("there are 2"),
            "{e}"
        );
        let e = set_value(SCENE, "materials.steel", "1").unwrap_err();
        assert!(e.contains("white, glass"), "{e}");
        assert!(
            apply_overrides(SCENE, &["camera.fov".into()])
                .unwrap_err()
                .contains("PATH=VALUE")
        );
        assert!(set_value(SCENE, "camera..fov", "1").is_err());
        assert!(set_value(SCENE, "shapes[x]", "1").is_err());
    }
}
