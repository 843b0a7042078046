//! The README's integrator tables document exactly the settings the integrators take: every field
//! of each settings struct has a row, and no row names a field that does not exist.

use lightlab_integrators::IntegratorConfig;
use std::collections::BTreeSet;

/// The fields named in the first column of the `| field | meaning | default |` table that follows
/// the paragraph introducing `` `{name}(...)` ``.
fn readme_fields(readme: &str, name: &str) -> BTreeSet<String> {
    let intro = format!("`{name}(...)`");
    let start = readme
        .lines()
        .position(|l| !l.starts_with('|') && l.contains(&intro) && l.contains('—'))
        .unwrap_or_else(|| panic!("README introduces no {intro}"));
    let table: Vec<&str> = readme
        .lines()
        .skip(start)
        .skip_while(|l| !l.starts_with("| field | meaning | default |"))
        .skip(2)
        .take_while(|l| l.starts_with('|'))
        .collect();
    assert!(!table.is_empty(), "no settings table after {intro}");
    table
        .iter()
        .flat_map(|row| {
            let first = row.split('|').nth(1).unwrap_or_default();
            first
                .split(',')
                .map(|f| f.trim().trim_matches('`').to_string())
                .collect::<Vec<_>>()
        })
        .collect()
}

/// The field names of an integrator's settings: those its parser expects, which its error for an
/// unknown field lists (all of them, also those left out when default settings are written, such
/// as `replicates`).
fn struct_fields(name: &str) -> BTreeSet<String> {
    let e = IntegratorConfig::from_ron(&format!("{name}(no_such_field: 0)"))
        .expect_err("an unknown field is an error")
        .to_string();
    let expected = e
        .split("expected one of")
        .nth(1)
        .unwrap_or_else(|| panic!("{name}: {e}"));
    expected
        .split('`')
        .skip(1)
        .step_by(2)
        .map(String::from)
        .collect()
}

#[test]
fn readme_integrator_tables_list_exactly_the_settings_fields() {
    let readme = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../README.md"))
        .expect("README.md");
    for name in [
        "Path",
        "Light",
        "Bdpt",
        "PhotonMap",
        "Ppm",
        "Sppm",
        "Vcm",
        "Radiosity",
    ] {
        let documented = readme_fields(&readme, name);
        let fields = struct_fields(name);
        let missing: Vec<_> = fields.difference(&documented).collect();
        let unknown: Vec<_> = documented.difference(&fields).collect();
        assert!(
            missing.is_empty() && unknown.is_empty(),
            "README table of {name}(...): fields without a row {missing:?}, rows without a field \
             {unknown:?}"
        );
    }
}
