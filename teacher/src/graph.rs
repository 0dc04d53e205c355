//! The teacher's weights file: a safetensors file whose tensors are the graph's float
//! constants (float16, as published) and whose metadata holds the graph itself (its nodes
//! in TensorFlow's op vocabulary, with their inputs and attributes) and its small integer
//! constants (shapes, permutations, paddings).
//!
//! Keeping the published graph, rather than a network retyped by hand, means the forward
//! pass runs what the NanoDet project exported, op for op; `interpret` checks each op it
//! meets and refuses one it does not know.

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use thiserror::Error;

/// The `format` the file's metadata names.
pub const FORMAT: &str = "team-ball teacher graph v1";

/// One attribute of a node, in the few kinds the graph uses.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Attr {
    Bool(bool),
    Int(i64),
    Float(f64),
    Ints(Vec<i64>),
    Text(String),
}

/// One node: an op over named inputs (`name` or `name:k` for an op's k-th output).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Node {
    pub name: String,
    pub op: String,
    #[serde(default)]
    pub inputs: Vec<String>,
    #[serde(default)]
    pub attrs: BTreeMap<String, Attr>,
}

/// An integer constant (shapes, permutations, paddings, split sizes).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct IntConst {
    pub shape: Vec<usize>,
    pub values: Vec<i64>,
}

/// A float constant (weights, biases), float16 as published.
#[derive(Debug, Clone, PartialEq)]
pub struct FloatConst {
    pub shape: Vec<usize>,
    /// Little-endian IEEE float16, `shape`'s product of them.
    pub f16_le: Vec<u8>,
}

/// The whole graph: nodes, constants, the input and the outputs.
#[derive(Debug, Clone, PartialEq)]
pub struct Graph {
    pub nodes: Vec<Node>,
    pub ints: BTreeMap<String, IntConst>,
    pub floats: BTreeMap<String, FloatConst>,
    pub input: String,
    /// The input's shape, NCHW.
    pub input_shape: Vec<usize>,
    pub outputs: Vec<String>,
    /// Where the graph came from (package, version, files), kept in the file.
    pub provenance: BTreeMap<String, String>,
}

/// Why a weights file cannot be read or written.
#[derive(Debug, Error)]
pub enum GraphError {
    #[error("not a safetensors file: {0}")]
    Format(String),
    #[error("the file is a {found:?}, not a {expected:?}")]
    WrongFormat { found: String, expected: String },
    #[error("metadata key {0:?} is missing")]
    MissingKey(&'static str),
    #[error("metadata {key:?} does not parse: {why}")]
    BadMetadata { key: &'static str, why: String },
    #[error("tensor {0:?} is not float16")]
    DType(String),
    #[error("constant {name:?} holds {found} bytes, its shape needs {expected}")]
    Size {
        name: String,
        expected: usize,
        found: usize,
    },
    #[error("node {node:?} reads {input:?}, which no node or constant makes")]
    Dangling { node: String, input: String },
}

#[derive(Serialize, Deserialize)]
struct Header {
    input: String,
    input_shape: Vec<usize>,
    outputs: Vec<String>,
}

impl Graph {
    /// The graph as a safetensors file.
    pub fn to_safetensors(&self) -> Result<Vec<u8>, GraphError> {
        let mut metadata: BTreeMap<String, String> = self
            .provenance
            .iter()
            .map(|(k, v)| (format!("source.{k}"), v.clone()))
            .collect();
        metadata.insert("format".into(), FORMAT.into());
        metadata.insert("graph".into(), to_json(&self.nodes)?);
        metadata.insert("ints".into(), to_json(&self.ints)?);
        let header = Header {
            input: self.input.clone(),
            input_shape: self.input_shape.clone(),
            outputs: self.outputs.clone(),
        };
        metadata.insert("io".into(), to_json(&header)?);
        // Written by hand rather than by `safetensors::serialize`, whose metadata map is
        // hashed: the same graph must give the same bytes, so that the recipe's output can
        // be compared with the committed file.
        let mut header = serde_json::Map::new();
        header.insert(
            "__metadata__".into(),
            serde_json::to_value(&metadata).map_err(|e| GraphError::Format(e.to_string()))?,
        );
        let mut offset = 0usize;
        for (name, c) in &self.floats {
            let expected = c.shape.iter().product::<usize>() * 2;
            if c.f16_le.len() != expected {
                return Err(GraphError::Size {
                    name: name.clone(),
                    expected,
                    found: c.f16_le.len(),
                });
            }
            header.insert(
                name.clone(),
                serde_json::json!({
                    "dtype": "F16",
                    "shape": c.shape,
                    "data_offsets": [offset, offset + expected],
                }),
            );
            offset += expected;
        }
        let mut text =
            serde_json::to_vec(&header).map_err(|e| GraphError::Format(e.to_string()))?;
        while text.len() % 8 != 0 {
            text.push(b' ');
        }
        let mut out = Vec::with_capacity(8 + text.len() + offset);
        out.extend((text.len() as u64).to_le_bytes());
        out.extend(text);
        for c in self.floats.values() {
            out.extend(&c.f16_le);
        }
        Ok(out)
    }

    /// The graph of a weights file, checked: every input a node reads is made somewhere.
    pub fn from_safetensors(bytes: &[u8]) -> Result<Self, GraphError> {
        let (_, meta) = safetensors::SafeTensors::read_metadata(bytes)
            .map_err(|e| GraphError::Format(e.to_string()))?;
        let metadata: BTreeMap<String, String> = meta
            .metadata()
            .as_ref()
            .map(|m| m.iter().map(|(k, v)| (k.clone(), v.clone())).collect())
            .unwrap_or_default();
        match metadata.get("format") {
            Some(f) if f == FORMAT => {}
            other => {
                return Err(GraphError::WrongFormat {
                    found: other
                        .cloned()
                        .unwrap_or_else(|| "file with no format".into()),
                    expected: FORMAT.into(),
                });
            }
        }
        fn parse<T: serde::de::DeserializeOwned>(
            metadata: &BTreeMap<String, String>,
            key: &'static str,
        ) -> Result<T, GraphError> {
            let text = metadata.get(key).ok_or(GraphError::MissingKey(key))?;
            serde_json::from_str(text).map_err(|e| GraphError::BadMetadata {
                key,
                why: e.to_string(),
            })
        }
        let nodes: Vec<Node> = parse(&metadata, "graph")?;
        let ints: BTreeMap<String, IntConst> = parse(&metadata, "ints")?;
        let header: Header = parse(&metadata, "io")?;
        let st = safetensors::SafeTensors::deserialize(bytes)
            .map_err(|e| GraphError::Format(e.to_string()))?;
        let mut floats = BTreeMap::new();
        for (name, view) in st.tensors() {
            if view.dtype() != safetensors::Dtype::F16 {
                return Err(GraphError::DType(name));
            }
            let expected = view.shape().iter().product::<usize>() * 2;
            if view.data().len() != expected {
                return Err(GraphError::Size {
                    name,
                    expected,
                    found: view.data().len(),
                });
            }
            floats.insert(
                name,
                FloatConst {
                    shape: view.shape().to_vec(),
                    f16_le: view.data().to_vec(),
                },
            );
        }
        for (name, c) in &ints {
            let expected = c.shape.iter().product::<usize>();
            if c.values.len() != expected {
                return Err(GraphError::Size {
                    name: name.clone(),
                    expected,
                    found: c.values.len(),
                });
            }
        }
        let provenance = metadata
            .iter()
            .filter_map(|(k, v)| {
                k.strip_prefix("source.")
                    .map(|k| (k.to_string(), v.clone()))
            })
            .collect();
        let graph = Graph {
            nodes,
            ints,
            floats,
            input: header.input,
            input_shape: header.input_shape,
            outputs: header.outputs,
            provenance,
        };
        graph.check_inputs()?;
        Ok(graph)
    }

    /// Every input a node reads is a node, a constant or the input.
    fn check_inputs(&self) -> Result<(), GraphError> {
        let made: std::collections::HashSet<&str> = self
            .nodes
            .iter()
            .map(|n| n.name.as_str())
            .chain(self.ints.keys().map(String::as_str))
            .chain(self.floats.keys().map(String::as_str))
            .collect();
        for node in &self.nodes {
            for input in &node.inputs {
                let base = input.split(':').next().unwrap_or(input);
                if !made.contains(base) {
                    return Err(GraphError::Dangling {
                        node: node.name.clone(),
                        input: input.clone(),
                    });
                }
            }
        }
        for output in &self.outputs {
            if !made.contains(output.as_str()) {
                return Err(GraphError::Dangling {
                    node: "(outputs)".into(),
                    input: output.clone(),
                });
            }
        }
        Ok(())
    }
}

fn to_json<T: Serialize>(value: &T) -> Result<String, GraphError> {
    serde_json::to_string(value).map_err(|e| GraphError::Format(e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tiny() -> Graph {
        let mut ints = BTreeMap::new();
        ints.insert(
            "perm".into(),
            IntConst {
                shape: vec![4],
                values: vec![0, 2, 3, 1],
            },
        );
        let mut floats = BTreeMap::new();
        floats.insert(
            "w".into(),
            FloatConst {
                shape: vec![2],
                f16_le: vec![0, 0x3c, 0, 0x40],
            },
        );
        Graph {
            nodes: vec![Node {
                name: "t".into(),
                op: "Transpose".into(),
                inputs: vec!["x".into(), "perm".into()],
                attrs: BTreeMap::new(),
            }],
            ints,
            floats,
            input: "x".into(),
            input_shape: vec![1, 3, 4, 4],
            outputs: vec!["t".into()],
            provenance: [("package".to_string(), "p@1".to_string())].into(),
        }
    }

    #[test]
    fn a_graph_survives_its_file() {
        let mut g = tiny();
        // The input is a placeholder node in real graphs.
        g.nodes.insert(
            0,
            Node {
                name: "x".into(),
                op: "Placeholder".into(),
                inputs: vec![],
                attrs: BTreeMap::new(),
            },
        );
        let bytes = g.to_safetensors().expect("serialises");
        let back = Graph::from_safetensors(&bytes).expect("reads");
        assert_eq!(back, g);
    }

    #[test]
    fn a_node_reading_nothing_is_refused() {
        let g = tiny();
        let bytes = g.to_safetensors().expect("serialises");
        let err = Graph::from_safetensors(&bytes).expect_err("x is made by no node");
        assert!(err.to_string().contains("\"x\""), "{err}");
    }

    #[test]
    fn another_weights_file_is_named_as_such() {
        let other = safetensors::serialize(
            Vec::<(String, safetensors::tensor::TensorView<'_>)>::new(),
            Some([("format".to_string(), "something else".to_string())].into()),
        )
        .expect("serialises");
        let err = Graph::from_safetensors(&other).expect_err("wrong format");
        assert!(err.to_string().contains("something else"), "{err}");
        assert!(Graph::from_safetensors(b"not a file").is_err());
    }
}
