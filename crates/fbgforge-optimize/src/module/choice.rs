//! The discrete choices a module optimisation tries: core material × insert material
//! (or a hollow core), from the settings or the design and the material library.

use super::settings::ModuleSettings;
use crate::materials::{MaterialLibrary, MaterialRole};
use crate::spec::{Design, Module};
use serde::Serialize;

/// One discrete choice: core material and insert material (None = hollow, Case II).
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Choice {
    /// Core material key.
    pub core_material: String,
    /// Insert material key, or None for a hollow core.
    pub insert_material: Option<String>,
}

impl std::fmt::Display for Choice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "core {} + {}",
            self.core_material,
            self.insert_material.as_deref().unwrap_or("hollow")
        )
    }
}

/// The design's module, or an error naming the design.
pub(super) fn module_of(d: &Design) -> anyhow::Result<&Module> {
    d.module
        .as_ref()
        .ok_or_else(|| anyhow::anyhow!("design `{}` has no [module] section to optimise", d.name))
}

/// The discrete choices: cores × (inserts + hollow).
pub fn choices(
    base: &Design,
    lib: &MaterialLibrary,
    settings: &ModuleSettings,
) -> anyhow::Result<Vec<Choice>> {
    let m = module_of(base)?;
    let proc_ = base.printer.process;
    let cores: Vec<String> = match &settings.cores {
        Some(c) => c.clone(),
        None => {
            let mut c: Vec<String> = m.cores.iter().map(|c| c.material.clone()).collect();
            c.extend(lib.for_role(MaterialRole::Core, proc_));
            c
        }
    };
    let inserts: Vec<Option<String>> = match &settings.inserts {
        Some(i) => i
            .iter()
            .map(|s| if s == "none" { None } else { Some(s.clone()) })
            .collect(),
        None => {
            let mut i: Vec<Option<String>> =
                m.inserts.iter().map(|i| Some(i.material.clone())).collect();
            i.extend(
                lib.for_role(MaterialRole::Insert, proc_)
                    .into_iter()
                    .map(Some),
            );
            i.push(None);
            i
        }
    };
    anyhow::ensure!(
        !cores.is_empty(),
        "no core material to try: the list is empty"
    );
    anyhow::ensure!(
        !inserts.is_empty(),
        "no insert to try: the list is empty (use `none` for a hollow core)"
    );
    let mut out: Vec<Choice> = Vec::new();
    for c in &cores {
        for i in &inserts {
            let ch = Choice {
                core_material: c.clone(),
                insert_material: i.clone(),
            };
            if !out.contains(&ch) {
                out.push(ch);
            }
        }
    }
    Ok(out)
}

/// The start design's own choice: its first core's material and its first insert (or
/// hollow when it lists none).
pub fn start_choice(base: &Design) -> anyhow::Result<Choice> {
    let m = module_of(base)?;
    Ok(Choice {
        core_material: m
            .cores
            .first()
            .ok_or_else(|| anyhow::anyhow!("the design lists no core"))?
            .material
            .clone(),
        insert_material: m.inserts.first().map(|i| i.material.clone()),
    })
}
