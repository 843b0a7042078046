//! The scene a command reads and the command-line changes to it, shared by `render` and `replay`,
//! so that a replay loads the scene exactly as the render did.

use clap::Args;
use lightlab_scene::{MAX_RESOLUTION, Scene};
use std::path::PathBuf;

#[derive(Args)]
pub struct SceneArgs {
    /// Scene file: RON, or a Mitsuba 3 XML file (`.xml`; see scenes/README.md, "Mitsuba scenes").
    pub scene: PathBuf,
    /// A parameter of a Mitsuba scene, NAME=VALUE (repeatable), overriding its <default> like
    /// Mitsuba's -D, e.g. `-D spp=64 -D res=512`.
    #[arg(long = "define", short = 'D', value_name = "NAME=VALUE", value_parser = parse_define)]
    define: Vec<(String, String)>,
    /// Override a value of the scene file, as PATH=VALUE with VALUE in RON (repeatable), e.g.
    /// `--set camera.fov=60 --set 'materials.white.albedo=(0.5, 0.5, 0.5)' --set
    /// 'shapes[2].material="glass"'`: field names, map keys and list indices. Only values written
    /// in the file can be overridden.
    #[arg(long = "set", value_name = "PATH=VALUE")]
    set: Vec<String>,
    /// Image size WIDTHxHEIGHT, overriding the scene's (the field of view along the smaller axis
    /// is kept), e.g. 640x480.
    #[arg(long, value_parser = parse_resolution)]
    resolution: Option<(u32, u32)>,
}

impl SceneArgs {
    /// The scene with its overrides, and for a Mitsuba file the integrator it asks for (read
    /// only when none is given on the command line, `integrator_given`) and its sample count.
    pub fn load(
        &self,
        integrator_given: bool,
    ) -> Result<(Scene, Option<String>, Option<u32>), String> {
        let (mut scene, integrator, spp) = self.load_file(integrator_given)?;
        if let Some((w, h)) = self.resolution {
            scene.camera = scene.camera.with_resolution(w, h);
        }
        Ok((scene, integrator, spp))
    }

    fn load_file(
        &self,
        integrator_given: bool,
    ) -> Result<(Scene, Option<String>, Option<u32>), String> {
        // `-D res=16 -D res=8` kept the last without a word.
        for (i, (name, _)) in self.define.iter().enumerate() {
            if self.define[..i].iter().any(|(n, _)| n == name) {
                return Err(format!(
                    "-D {name} is given twice: give each parameter once"
                ));
            }
        }
        if lightlab_scene::mitsuba::is_mitsuba(&self.scene) {
            if !self.set.is_empty() {
                return Err(format!(
                    "--set edits RON scenes; {} is a Mitsuba file: override its parameters with -D NAME=VALUE",
                    self.scene.display()
                ));
            }
            let imported = lightlab_scene::mitsuba::import(&self.scene, &self.define)
                .map_err(|e| e.to_string())?;
            let integrator = match (integrator_given, imported.integrator) {
                (false, Some(i)) => Some(i.map_err(|e| e.to_string())?),
                _ => None,
            };
            let mut scene = lightlab_scene::build_scene(imported.desc, &self.scene)
                .map_err(|e| e.to_string())?;
            scene.warnings.extend(imported.notes);
            return Ok((scene, integrator, imported.spp));
        }
        if !self.define.is_empty() {
            return Err(format!(
                "-D sets parameters of Mitsuba scenes; {} is RON: use --set PATH=VALUE",
                self.scene.display()
            ));
        }
        let text =
            lightlab_scene::text::read_text(&self.scene).map_err(|e| e.located(&self.scene))?;
        let text = lightlab_scene::overrides::apply_overrides(&text, &self.set)?;
        let scene = lightlab_scene::parse_scene(&text, &self.scene).map_err(|e| {
            if self.set.is_empty() {
                e.to_string()
            } else {
                format!("{e} (after the --set overrides)")
            }
        })?;
        Ok((scene, None, None))
    }

    /// The scene and its overrides as arguments of another command, shell-quoted.
    pub fn command_line(&self) -> String {
        let mut words = vec![shell_quote(&self.scene.display().to_string())];
        for (name, value) in &self.define {
            words.push(format!("-D {}", shell_quote(&format!("{name}={value}"))));
        }
        for set in &self.set {
            words.push(format!("--set {}", shell_quote(set)));
        }
        if let Some((w, h)) = self.resolution {
            words.push(format!("--resolution {w}x{h}"));
        }
        words.join(" ")
    }
}

/// `word` as one POSIX shell word: as it is when it holds nothing the shell would change, else
/// in single quotes (a quote inside written '\'').
pub fn shell_quote(word: &str) -> String {
    let plain = |c: char| c.is_ascii_alphanumeric() || "-_./=,:+@%".contains(c);
    if !word.is_empty() && word.chars().all(plain) {
        word.to_string()
    } else {
        format!("'{}'", word.replace('\'', r"'\''"))
    }
}

/// `640x480` (or `640,480`).
pub fn parse_resolution(s: &str) -> Result<(u32, u32), String> {
    let bad = || {
        format!(
            "'{s}' is not a resolution: write WIDTHxHEIGHT, e.g. 640x480, each 1…{MAX_RESOLUTION}"
        )
    };
    let (w, h) = s.split_once(['x', 'X', ',']).ok_or_else(bad)?;
    let (w, h): (u32, u32) = (
        w.trim().parse().map_err(|_| bad())?,
        h.trim().parse().map_err(|_| bad())?,
    );
    if !(1..=MAX_RESOLUTION).contains(&w) || !(1..=MAX_RESOLUTION).contains(&h) {
        return Err(bad());
    }
    Ok((w, h))
}

/// `NAME=VALUE` of `-D`.
fn parse_define(s: &str) -> Result<(String, String), String> {
    match s.split_once('=') {
        Some((n, v)) if !n.trim().is_empty() => Ok((n.trim().to_string(), v.to_string())),
        _ => Err(format!("'{s}' is not NAME=VALUE, e.g. spp=64")),
    }
}

#[cfg(test)]
mod tests {
    use super::shell_quote;

    #[test]
    fn quotes_for_the_shell() {
        assert_eq!(
            shell_quote("scenes/cornell-box.ron"),
            "scenes/cornell-box.ron"
        );
        assert_eq!(
            shell_quote("Bdpt(max_bounces: 6)"),
            "'Bdpt(max_bounces: 6)'"
        );
        assert_eq!(
            shell_quote("shapes[2].material=\"it's\""),
            r#"'shapes[2].material="it'\''s"'"#
        );
        assert_eq!(shell_quote(""), "''");
    }
}
