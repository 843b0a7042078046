//! Reading Mitsuba 3 XML: the files (with `<include>`), `<default>` parameters and `$name`
//! substitution, into an owned element tree in which every element remembers its file, line and
//! column for error messages.

use crate::SceneError;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::rc::Rc;

/// Where an element starts: file, 1-based line and column.
#[derive(Clone, Debug)]
pub(crate) struct Location {
    pub file: Rc<PathBuf>,
    pub line: usize,
    pub col: usize,
}

impl Location {
    /// An error at this location.
    pub fn error(&self, message: impl Into<String>) -> SceneError {
        SceneError::Invalid {
            path: self.file.to_path_buf(),
            line: self.line,
            col: self.col,
            message: message.into(),
        }
    }
}

/// An XML element with its attributes (parameters substituted) and child elements.
#[derive(Debug)]
pub(crate) struct Element {
    pub tag: String,
    pub attrs: Vec<(String, String)>,
    pub children: Vec<Element>,
    pub at: Location,
}

impl Element {
    pub fn attr(&self, name: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_str())
    }

    /// A required attribute.
    pub fn require(&self, name: &str) -> Result<&str, SceneError> {
        self.attr(name).ok_or_else(|| {
            self.at
                .error(format!("<{}> needs a '{name}' attribute", self.tag))
        })
    }

    /// Rejects attributes other than `allowed`.
    pub fn only_attrs(&self, allowed: &[&str]) -> Result<(), SceneError> {
        match self
            .attrs
            .iter()
            .find(|(n, _)| !allowed.contains(&n.as_str()))
        {
            Some((n, _)) => Err(self.at.error(format!(
                "<{}> has an unknown attribute '{n}' (allowed: {})",
                self.tag,
                allowed.join(", ")
            ))),
            None => Ok(()),
        }
    }
}

/// Scene parameters: `<default>` values, overridden by the command line's `-D name=value`.
pub(crate) struct Params {
    values: BTreeMap<String, String>,
    /// Names given on the command line, and whether the scene used them.
    defines: BTreeMap<String, bool>,
}

impl Params {
    pub fn new(defines: &[(String, String)]) -> Params {
        Params {
            values: defines.iter().cloned().collect(),
            defines: defines.iter().map(|(n, _)| (n.clone(), false)).collect(),
        }
    }

    /// A `-D` name the scene never refers to is a typo, or a parameter of another scene.
    pub fn check_used(&self, root: &Path) -> Result<(), SceneError> {
        match self.defines.iter().find(|(_, used)| !**used) {
            Some((name, _)) => Err(SceneError::Invalid {
                path: root.to_path_buf(),
                line: 1,
                col: 1,
                message: format!(
                    "-D {name}=…: the scene never refers to ${name} (its other parameters: {})",
                    {
                        // The scene's own parameters, not the unused -D names themselves.
                        let own: Vec<&str> = self
                            .values
                            .keys()
                            .filter(|k| self.defines.get(*k) != Some(&false))
                            .map(String::as_str)
                            .collect();
                        if own.is_empty() {
                            "none".to_string()
                        } else {
                            own.join(", ")
                        }
                    }
                ),
            }),
            None => Ok(()),
        }
    }

    /// `value` with every `$name` replaced by the parameter's value (Mitsuba 3's substitution).
    fn substitute(&mut self, value: &str, at: &Location) -> Result<String, SceneError> {
        let mut out = String::with_capacity(value.len());
        let mut rest = value;
        while let Some(i) = rest.find('$') {
            out.push_str(&rest[..i]);
            let after = &rest[i + 1..];
            let len = after
                .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                .unwrap_or(after.len());
            let name = &after[..len];
            if name.is_empty() {
                return Err(at.error(format!(
                    "'{value}': '$' must be followed by a parameter name"
                )));
            }
            let v = self.values.get(name).ok_or_else(|| {
                at.error(format!(
                    "${name} is not defined: declare <default name=\"{name}\" value=\"…\"/> or \
                     pass -D {name}=…"
                ))
            })?;
            out.push_str(v);
            if let Some(used) = self.defines.get_mut(name) {
                *used = true;
            }
            rest = &after[len..];
        }
        out.push_str(rest);
        Ok(out)
    }
}

/// Reads `path` (a `<scene>` file) and the files it includes into the list of the scene's elements.
pub(crate) fn read_scene(path: &Path, params: &mut Params) -> Result<Vec<Element>, SceneError> {
    let mut includes = Includes {
        stack: vec![canonical(path)],
        files: 1,
    };
    read_file(path, params, &mut includes)
}

/// Most files one scene may read through `<include>`s: a chain of files each including the next
/// twice, a few kilobytes in all, expands to 2^depth copies (2²⁰ took 15 s and 1.5 GB).
const MAX_INCLUDED_FILES: usize = 4096;

/// The files being read, outermost first (canonical: `sub/../a.xml` is `a.xml`, so a cycle
/// through it is found), and how many have been read.
struct Includes {
    stack: Vec<PathBuf>,
    files: usize,
}

fn canonical(path: &Path) -> PathBuf {
    path.canonicalize().unwrap_or_else(|_| path.to_path_buf())
}

fn read_file(
    path: &Path,
    params: &mut Params,
    includes: &mut Includes,
) -> Result<Vec<Element>, SceneError> {
    let text = crate::text::read_text(path).map_err(|e| SceneError::reading(path, e))?;
    let file = Rc::new(path.to_path_buf());
    let doc = roxmltree::Document::parse(&text).map_err(|e| {
        let (line, col) = match e {
            // roxmltree places this at 1:1; the fault is where the file stops.
            roxmltree::Error::UnclosedRootNode => crate::error::line_col(&text, text.len()),
            _ => (e.pos().row as usize, e.pos().col as usize),
        };
        SceneError::Invalid {
            path: path.to_path_buf(),
            line,
            col,
            message: match e {
                roxmltree::Error::UnclosedRootNode => format!(
                    "not well-formed XML: the file ends before its root element closes (is it \
                     truncated?) [{e}]"
                ),
                _ => format!("not well-formed XML: {e}"),
            },
        }
    })?;
    let locate = |node: roxmltree::Node| {
        let pos = doc.text_pos_at(node.range().start);
        Location {
            file: file.clone(),
            line: pos.row as usize,
            col: pos.col as usize,
        }
    };
    let root = doc.root_element();
    let at = locate(root);
    if root.tag_name().name() != "scene" {
        return Err(at.error(format!(
            "the root element is <{}>; a Mitsuba scene file starts with <scene version=\"3.0.0\">",
            root.tag_name().name()
        )));
    }
    let version = root
        .attribute("version")
        .ok_or_else(|| at.error("<scene> needs a version attribute, e.g. version=\"3.0.0\""))?;
    let major: u32 = version
        .split('.')
        .next()
        .and_then(|m| m.trim().parse().ok())
        .ok_or_else(|| at.error(format!("<scene version=\"{version}\"> is not a version")))?;
    if major < 2 {
        return Err(at.error(format!(
            "scene version {version} is Mitsuba 0.x syntax (camelCase parameters); only version \
             2 and 3 files are read — upgrade it with Mitsuba 3 (it converts old files on load)"
        )));
    }
    // Defaults first (Mitsuba declares them at the top): the command line's -D values win.
    for node in root.children().filter(|n| n.is_element()) {
        if node.tag_name().name() == "default" {
            let at = locate(node);
            let name = node
                .attribute("name")
                .ok_or_else(|| at.error("<default> needs a name"))?;
            let value = node
                .attribute("value")
                .ok_or_else(|| at.error("<default> needs a value"))?;
            params
                .values
                .entry(name.to_string())
                .or_insert_with(|| value.to_string());
        }
    }
    let mut elements = Vec::new();
    for node in root.children().filter(|n| n.is_element()) {
        match node.tag_name().name() {
            "default" => {}
            "include" => {
                let at = locate(node);
                let name = params.substitute(
                    node.attribute("filename")
                        .ok_or_else(|| at.error("<include> needs a filename"))?,
                    &at,
                )?;
                let included = path.parent().unwrap_or(Path::new(".")).join(&name);
                if !included.is_file() {
                    return Err(at.error(format!(
                        "included file {} {}",
                        included.display(),
                        if included.exists() {
                            "is not a file"
                        } else {
                            "does not exist"
                        }
                    )));
                }
                let key = canonical(&included);
                if includes.stack.contains(&key) {
                    return Err(at.error(format!("{name} includes itself (directly or not)")));
                }
                includes.files += 1;
                if includes.files > MAX_INCLUDED_FILES {
                    return Err(at.error(format!(
                        "the scene reads more than {MAX_INCLUDED_FILES} files through <include> \
                         (files including others more than once multiply)"
                    )));
                }
                includes.stack.push(key);
                elements.extend(read_file(&included, params, includes)?);
                includes.stack.pop();
            }
            _ => elements.push(element(node, params, &locate, 1)?),
        }
    }
    Ok(elements)
}

/// The deepest nesting of elements read (Mitsuba scenes nest a handful: a shape, its BSDF, a
/// two-sided wrapper, a texture, a transform): 20 000 nested `twosided` overflowed the stack.
const MAX_NESTING: usize = 64;

fn element(
    node: roxmltree::Node,
    params: &mut Params,
    locate: &dyn Fn(roxmltree::Node) -> Location,
    depth: usize,
) -> Result<Element, SceneError> {
    let at = locate(node);
    if depth > MAX_NESTING {
        return Err(at.error(format!(
            "elements are nested more than {MAX_NESTING} deep here"
        )));
    }
    let mut attrs = Vec::new();
    for a in node.attributes() {
        attrs.push((a.name().to_string(), params.substitute(a.value(), &at)?));
    }
    let mut children = Vec::new();
    for child in node.children() {
        if child.is_element() {
            children.push(element(child, params, locate, depth + 1)?);
        } else if child.is_text() && !child.text().unwrap_or("").trim().is_empty() {
            return Err(locate(child).error(format!(
                "text inside <{}> is not part of Mitsuba's format (values go in attributes)",
                node.tag_name().name()
            )));
        }
    }
    Ok(Element {
        tag: node.tag_name().name().to_string(),
        attrs,
        children,
        at,
    })
}
