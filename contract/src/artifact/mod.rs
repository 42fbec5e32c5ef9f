//! Typed values that flow between stages, and their canonical binary encoding.
//!
//! The encoding (postcard of the enum) is deterministic: the same value always gives the same
//! bytes, so the blake3 digest of the bytes is the artifact's identity and drives early cutoff.

use serde::{Deserialize, Serialize};

pub mod basis;
pub mod complex_modes;
pub mod equilibrium;
pub mod material;
pub mod mesh;
pub mod model;

pub use basis::Basis;
pub use complex_modes::{ComplexMode, ComplexModes, ComplexShape, ShapeMatrices};
pub use equilibrium::{ContactFrames, Equilibrium};
pub use material::{ElasticLaw, Material};
pub use mesh::{ContactPair, Element, ElementKind, Elements, Mesh};
pub use model::{CscMatrix, Model, RealModes, TiedNode};

use crate::table::Table;

/// The version of the artifacts' encoding, part of every cache key: raise it when an artifact
/// type changes its layout, so that no entry is decoded with another layout.
/// 2: meshes hold elements of several kinds.
/// 3: a contact pair holds weighted node sets on each side (`ContactPair::pad`, `disc`).
/// 4: a model holds its tied nodes (`Model::tied`, one more byte when there are none).
pub const ENCODING_VERSION: u32 = 4;

/// A value produced by one stage and consumed by others.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Artifact {
    /// Columns of equal length; written to Parquet by the engine.
    Table(Table),
    /// A rendered figure; written as `<output>.svg` and `<output>.png` by the engine.
    Figure(Figure),
    /// A file in a format other tools read (VTU for ParaView, Matrix Market for scipy);
    /// written as `<output>.<extension>` by the engine.
    Document(Document),
    Mesh(Box<Mesh>),
    Model(Box<Model>),
    RealModes(Box<RealModes>),
    Equilibrium(Box<Equilibrium>),
    Basis(Box<Basis>),
    ComplexModes(Box<ComplexModes>),
    /// Last, so that the variants before it keep their encoding.
    Material(Box<Material>),
}

/// Bytes of a file format, with the extension it is written under.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Document {
    pub extension: String,
    pub bytes: Vec<u8>,
}

/// A figure rendered by a stage, in both formats people use: SVG for papers, PNG for a look.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Figure {
    pub svg: String,
    pub png: Vec<u8>,
}

/// The type of an [`Artifact`], used to check that an output may feed an input.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ArtifactType {
    Table,
    Figure,
    Document,
    Mesh,
    Model,
    RealModes,
    Equilibrium,
    Basis,
    ComplexModes,
    Material,
}

impl ArtifactType {
    pub fn name(self) -> &'static str {
        match self {
            ArtifactType::Table => "table",
            ArtifactType::Figure => "figure",
            ArtifactType::Document => "document",
            ArtifactType::Mesh => "mesh",
            ArtifactType::Model => "model",
            ArtifactType::RealModes => "real modes",
            ArtifactType::Equilibrium => "equilibrium",
            ArtifactType::Basis => "basis",
            ArtifactType::ComplexModes => "complex modes",
            ArtifactType::Material => "material",
        }
    }
}

impl std::fmt::Display for ArtifactType {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// A value an [`Artifact`] variant holds: what a stage reads from an input port with
/// [`Inputs::get`](crate::stage::Inputs::get).
pub trait ArtifactValue {
    const TYPE: ArtifactType;
    fn from_artifact(artifact: &Artifact) -> Option<&Self>;
}

macro_rules! artifact_value {
    ($($variant:ident($value:ty)),* $(,)?) => {$(
        impl ArtifactValue for $value {
            const TYPE: ArtifactType = ArtifactType::$variant;
            fn from_artifact(artifact: &Artifact) -> Option<&Self> {
                match artifact {
                    Artifact::$variant(value) => {
                        // Deref coercion: the boxed variants give their content.
                        let value: &$value = value;
                        Some(value)
                    }
                    _ => None,
                }
            }
        }
    )*};
}

artifact_value!(
    Table(Table),
    Figure(Figure),
    Document(Document),
    Mesh(Mesh),
    Model(Model),
    RealModes(RealModes),
    Equilibrium(Equilibrium),
    Basis(Basis),
    ComplexModes(ComplexModes),
    Material(Material),
);

/// The bytes could not be decoded as an artifact (a corrupt or foreign cache object).
#[derive(Debug, thiserror::Error)]
#[error("cannot decode artifact: {0}")]
pub struct DecodeError(String);

impl Artifact {
    pub fn artifact_type(&self) -> ArtifactType {
        match self {
            Artifact::Table(_) => ArtifactType::Table,
            Artifact::Figure(_) => ArtifactType::Figure,
            Artifact::Document(_) => ArtifactType::Document,
            Artifact::Mesh(_) => ArtifactType::Mesh,
            Artifact::Model(_) => ArtifactType::Model,
            Artifact::RealModes(_) => ArtifactType::RealModes,
            Artifact::Equilibrium(_) => ArtifactType::Equilibrium,
            Artifact::Basis(_) => ArtifactType::Basis,
            Artifact::ComplexModes(_) => ArtifactType::ComplexModes,
            Artifact::Material(_) => ArtifactType::Material,
        }
    }

    /// Canonical encoding: equal values give equal bytes.
    pub fn encode(&self) -> Vec<u8> {
        postcard::to_stdvec(self).expect("encoding an in-memory artifact cannot fail")
    }

    pub fn decode(bytes: &[u8]) -> Result<Artifact, DecodeError> {
        postcard::from_bytes(bytes).map_err(|err| DecodeError(err.to_string()))
    }

    /// A text file of a format other tools read, written as `<output>.<extension>`.
    pub fn document(extension: &str, text: String) -> Artifact {
        Artifact::Document(Document {
            extension: extension.to_string(),
            bytes: text.into_bytes(),
        })
    }

    pub fn as_table(&self) -> Option<&Table> {
        match self {
            Artifact::Table(table) => Some(table),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn encoding_round_trips_and_is_deterministic() {
        let table = Table::new()
            .with("t", vec![0.0, 0.5, 1.0])
            .with("label", vec!["a".to_string(), "b".into(), "c".into()]);
        let artifact = Artifact::Table(table);
        let bytes = artifact.encode();
        assert_eq!(bytes, artifact.clone().encode());
        assert_eq!(Artifact::decode(&bytes).unwrap(), artifact);
    }

    #[test]
    fn truncated_bytes_do_not_decode() {
        let bytes = Artifact::Table(Table::new().with("x", vec![1.0, 2.0])).encode();
        assert!(Artifact::decode(&bytes[..bytes.len() - 3]).is_err());
    }
}
