//! The optimiser's material library: elastic constants the model needs plus the
//! viscoelastic and linearity numbers of the Q model, per printable material.
//!
//! The shipped library is `designs/library/materials.toml` (compiled in); a user library in the
//! same format replaces it. A design's own material table only holds E and ν, so a
//! design material that is not in the library gets class defaults chosen by its
//! modulus ([`ViscoParams::class_default`]).

use crate::spec::{Material, PrintProcess};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

/// The shipped library, `designs/library/materials.toml`.
pub(crate) const SHIPPED_LIBRARY_TOML: &str =
    include_str!("../../../designs/library/materials.toml");

/// Which process makes a library material.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum MaterialProcess {
    /// Material jetting (Stratasys J750 and similar).
    Polyjet,
    /// Fused deposition modelling.
    Fdm,
    /// Cast (silicone sheets); never offered for printed parts.
    Cast,
}

impl MaterialProcess {
    /// True when a printer of `p` makes this material.
    pub(crate) fn printed_by(self, p: PrintProcess) -> bool {
        matches!(
            (self, p),
            (MaterialProcess::Polyjet, PrintProcess::Polyjet)
                | (MaterialProcess::Fdm, PrintProcess::Fdm)
        )
    }
}

/// Which part a library material is offered for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum MaterialRole {
    /// Plug-in sensor core (the grating host, soft).
    Core,
    /// Solid insert.
    Insert,
    /// Clip-on cap.
    Cap,
    /// Cast array sheet.
    Array,
}

/// Viscoelastic and linearity parameters of one material (Q model inputs).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub(crate) struct ViscoParams {
    /// Relaxation time τ of the standard linear solid, s.
    pub relaxation_time_s: f64,
    /// Instant over relaxed modulus, E_u / E_r ≥ 1 (1 = purely elastic).
    pub unrelaxed_to_relaxed_ratio: f64,
    /// Hyperelastic stiffening coefficient (1 = neo-Hookean, 0 = linear).
    pub nonlinearity: f64,
}

impl ViscoParams {
    /// Defaults by material class when a design material is not in the library:
    /// rubber-like below 10 MPa, flexible below 200 MPa, rigid above. These are the
    /// library's typical values for each class (assumptions, see docs/optimize.md).
    pub(crate) fn class_default(youngs_modulus_mpa: f64) -> Self {
        if youngs_modulus_mpa < 10.0 {
            ViscoParams {
                relaxation_time_s: 1.0,
                unrelaxed_to_relaxed_ratio: 1.8,
                nonlinearity: 1.0,
            }
        } else if youngs_modulus_mpa < 200.0 {
            ViscoParams {
                relaxation_time_s: 1.0,
                unrelaxed_to_relaxed_ratio: 1.3,
                nonlinearity: 0.5,
            }
        } else {
            ViscoParams {
                relaxation_time_s: 5.0,
                unrelaxed_to_relaxed_ratio: 1.03,
                nonlinearity: 0.0,
            }
        }
    }
}

/// One library material.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LibraryMaterial {
    /// Process that makes it.
    pub process: MaterialProcess,
    /// Parts it is offered for.
    pub roles: Vec<MaterialRole>,
    /// Relaxed (quasi-static) Young's modulus, MPa.
    pub youngs_modulus_mpa: f64,
    /// Poisson's ratio.
    pub poisson_ratio: f64,
    /// Relaxation time τ of the standard linear solid, s.
    pub relaxation_time_s: f64,
    /// E_u / E_r of the standard linear solid, ≥ 1.
    pub unrelaxed_to_relaxed_ratio: f64,
    /// Hyperelastic stiffening coefficient, ≥ 0.
    pub nonlinearity: f64,
    /// Where the numbers come from.
    pub source: String,
}

impl LibraryMaterial {
    /// The elastic part, as a design's material table holds it.
    pub fn to_spec_material(&self) -> Material {
        Material {
            youngs_modulus_mpa: self.youngs_modulus_mpa,
            poisson_ratio: self.poisson_ratio,
            note: Some(self.source.clone()),
            permissible_strain_percent: None,
            vendor_name: None,
            shore_hardness: None,
            display_colour: None,
            hysteresis_limit_percent_span: None,
        }
    }

    /// The viscoelastic part.
    pub(crate) fn visco(&self) -> ViscoParams {
        ViscoParams {
            relaxation_time_s: self.relaxation_time_s,
            unrelaxed_to_relaxed_ratio: self.unrelaxed_to_relaxed_ratio,
            nonlinearity: self.nonlinearity,
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct LibraryFile {
    #[serde(default)]
    materials: BTreeMap<String, LibraryMaterial>,
}

/// A validated material library: name → material.
#[derive(Debug, Clone, PartialEq)]
pub struct MaterialLibrary {
    /// The materials, by name.
    pub materials: BTreeMap<String, LibraryMaterial>,
}

impl MaterialLibrary {
    /// The shipped library.
    pub fn shipped() -> Self {
        Self::parse(SHIPPED_LIBRARY_TOML, "designs/library/materials.toml")
            .expect("the shipped material library is valid")
    }

    /// Load a library file.
    pub fn load(path: &Path) -> anyhow::Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|e| {
            anyhow::anyhow!("{}: cannot read the material library: {e}", path.display())
        })?;
        Self::parse(&text, &path.display().to_string())
    }

    /// Parse and validate a library; `origin` names the file in errors.
    pub fn parse(text: &str, origin: &str) -> anyhow::Result<Self> {
        let file: LibraryFile = toml::from_str(text).map_err(|e| {
            let line = e
                .span()
                .map(|s| text[..s.start.min(text.len())].matches('\n').count() + 1)
                .unwrap_or(0);
            anyhow::anyhow!("{origin}: line {line}: {}", e.message())
        })?;
        if file.materials.is_empty() {
            anyhow::bail!(
                "{origin}: the material table is empty; list at least one [materials.NAME] entry"
            );
        }
        for (name, m) in &file.materials {
            let f = |field: &str| format!("{origin}: field `materials.{name}.{field}`");
            let checks = [
                ("youngs_modulus_mpa", m.youngs_modulus_mpa, 1e-4, 1e7),
                ("poisson_ratio", m.poisson_ratio, 0.0, 0.4999),
                ("relaxation_time_s", m.relaxation_time_s, 0.0, 1e5),
                (
                    "unrelaxed_to_relaxed_ratio",
                    m.unrelaxed_to_relaxed_ratio,
                    1.0,
                    100.0,
                ),
                ("nonlinearity", m.nonlinearity, 0.0, 10.0),
            ];
            for (field, v, lo, hi) in checks {
                if !v.is_finite() || v < lo || v > hi {
                    anyhow::bail!("{}: {v} is out of range; allowed {lo} to {hi}", f(field));
                }
            }
            if m.youngs_modulus_mpa <= 0.0 {
                anyhow::bail!("{}: must be positive", f("youngs_modulus_mpa"));
            }
            if m.roles.is_empty() {
                anyhow::bail!(
                    "{}: list at least one role (core, insert, cap, array)",
                    f("roles")
                );
            }
        }
        Ok(MaterialLibrary {
            materials: file.materials,
        })
    }

    /// Names of the materials a printer of `process` makes for `role`.
    pub fn for_role(&self, role: MaterialRole, process: PrintProcess) -> Vec<String> {
        self.materials
            .iter()
            .filter(|(_, m)| m.roles.contains(&role) && m.process.printed_by(process))
            .map(|(k, _)| k.clone())
            .collect()
    }

    /// Smallest and largest modulus (MPa) of the materials a printer of `process`
    /// makes for `role`: `sweep`'s default range for a modulus parameter. `None` when
    /// the library offers no such material.
    pub fn modulus_range(&self, role: MaterialRole, process: PrintProcess) -> Option<(f64, f64)> {
        self.for_role(role, process)
            .iter()
            .map(|k| self.materials[k].youngs_modulus_mpa)
            .fold(None, |r, e| match r {
                None => Some((e, e)),
                Some((lo, hi)) => Some((f64::min(lo, e), f64::max(hi, e))),
            })
    }

    /// Viscoelastic parameters of a design material: the library entry of the same
    /// name, else class defaults from its modulus.
    pub(crate) fn visco_for(&self, name: &str, m: &Material) -> ViscoParams {
        match self.materials.get(name) {
            Some(l) => l.visco(),
            None => ViscoParams::class_default(m.youngs_modulus_mpa),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shipped_library_has_the_papers_materials_and_both_processes() {
        let lib = MaterialLibrary::shipped();
        // The paper's moduli (reference §1) are carried unchanged.
        let e = |k: &str| lib.materials[k].youngs_modulus_mpa;
        assert_eq!(e("core_rubber_case_i"), 3.2);
        assert_eq!(e("core_rubber_case_ii"), 1.4);
        assert_eq!(e("cap_digital_abs"), 44.0);
        assert_eq!(e("insert_blue"), 2000.0);
        assert_eq!(e("insert_green"), 720.0);
        assert_eq!(e("insert_light_green"), 30.0);
        assert!(lib
            .for_role(MaterialRole::Core, PrintProcess::Fdm)
            .contains(&"tpu_95a".to_string()));
        assert!(lib
            .for_role(MaterialRole::Core, PrintProcess::Polyjet)
            .contains(&"agilus30".to_string()));
        assert!(!lib
            .for_role(MaterialRole::Insert, PrintProcess::Polyjet)
            .contains(&"pla".to_string()));
    }

    #[test]
    fn bad_libraries_are_rejected_with_the_field() {
        let e = MaterialLibrary::parse("", "lib.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("empty"), "{e}");
        let bad = "[materials.x]\nprocess='fdm'\nroles=['core']\nyoungs_modulus_mpa=-1\npoisson_ratio=0.3\nrelaxation_time_s=1\nunrelaxed_to_relaxed_ratio=1.2\nnonlinearity=0\nsource='t'\n";
        let e = MaterialLibrary::parse(bad, "lib.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("materials.x.youngs_modulus_mpa"), "{e}");
        let e = MaterialLibrary::parse("[materials.x]\nprocess='fdm'\n", "lib.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("lib.toml: line"), "{e}");
    }
}
