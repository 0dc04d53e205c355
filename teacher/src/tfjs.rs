//! Reading a TF.js graph model (`model.json`: the topology and a weights manifest; one
//! `.bin` of the weights, concatenated in the manifest's order) into a [`Graph`].
//!
//! The manifest's float weights are stored quantised to float16 (`quantization.dtype`),
//! which the graph keeps as they are; integer constants (int32) become the graph's
//! integer constants. Nothing is computed here: the converter is a change of container.

use crate::graph::{Attr, FloatConst, Graph, IntConst, Node};
use base64::Engine as _;
use serde::Deserialize;
use std::collections::BTreeMap;
use thiserror::Error;

/// Why a TF.js model cannot be converted.
#[derive(Debug, Error)]
pub enum TfjsError {
    #[error("model.json does not parse: {0}")]
    Json(String),
    #[error("model.json has {0} weight files; the teacher's model has one")]
    WeightFiles(usize),
    #[error("weight {name:?}: {why}")]
    Weight { name: String, why: String },
    #[error("the weights file holds {found} bytes, the manifest needs {expected}")]
    BinSize { expected: usize, found: usize },
    #[error("the model has no input placeholder")]
    NoInput,
    #[error("node {node:?}: attribute {attr:?} is not understood")]
    Attr { node: String, attr: String },
}

#[derive(Deserialize)]
struct ModelJson {
    #[serde(rename = "modelTopology")]
    topology: Topology,
    #[serde(rename = "weightsManifest")]
    manifest: Vec<ManifestGroup>,
    #[serde(default)]
    signature: Option<serde_json::Value>,
}

#[derive(Deserialize)]
struct Topology {
    node: Vec<TfNode>,
}

#[derive(Deserialize)]
struct TfNode {
    name: String,
    op: String,
    #[serde(default)]
    input: Vec<String>,
    #[serde(default)]
    attr: BTreeMap<String, serde_json::Value>,
}

#[derive(Deserialize)]
struct ManifestGroup {
    paths: Vec<String>,
    weights: Vec<ManifestWeight>,
}

#[derive(Deserialize)]
struct ManifestWeight {
    name: String,
    shape: Vec<usize>,
    dtype: String,
    #[serde(default)]
    quantization: Option<Quantization>,
}

#[derive(Deserialize)]
struct Quantization {
    dtype: String,
}

/// The graph of a TF.js model: `model_json` the topology and manifest, `bin` its one
/// weights file. `provenance` is written into the converted file.
pub fn read(
    model_json: &[u8],
    bin: &[u8],
    provenance: BTreeMap<String, String>,
) -> Result<Graph, TfjsError> {
    let model: ModelJson =
        serde_json::from_slice(model_json).map_err(|e| TfjsError::Json(e.to_string()))?;
    if model.manifest.len() != 1 || model.manifest[0].paths.len() != 1 {
        return Err(TfjsError::WeightFiles(
            model.manifest.iter().map(|g| g.paths.len()).sum(),
        ));
    }
    let (ints, floats) = weights(&model.manifest[0].weights, bin)?;
    let mut nodes = Vec::new();
    let mut input = None;
    let mut input_shape = Vec::new();
    for n in &model.topology.node {
        if n.op == "Const" {
            continue;
        }
        if n.op == "Placeholder" {
            input = Some(n.name.clone());
            input_shape = placeholder_shape(&n.attr);
        }
        nodes.push(Node {
            name: n.name.clone(),
            op: n.op.clone(),
            // Control inputs (`^name`) order execution only; the graph runs in data order.
            inputs: n
                .input
                .iter()
                .filter(|i| !i.starts_with('^'))
                .cloned()
                .collect(),
            attrs: attrs(n)?,
        });
    }
    let input = input.ok_or(TfjsError::NoInput)?;
    let outputs = outputs(&model, &nodes);
    Ok(Graph {
        nodes,
        ints,
        floats,
        input,
        input_shape,
        outputs,
        provenance,
    })
}

type Consts = (BTreeMap<String, IntConst>, BTreeMap<String, FloatConst>);

fn weights(manifest: &[ManifestWeight], bin: &[u8]) -> Result<Consts, TfjsError> {
    let mut ints = BTreeMap::new();
    let mut floats = BTreeMap::new();
    let mut offset = 0usize;
    for w in manifest {
        let count: usize = w.shape.iter().product();
        let stored = match (&w.dtype[..], w.quantization.as_ref().map(|q| &q.dtype[..])) {
            ("float32", Some("float16")) => 2,
            ("int32", None) => 4,
            (dtype, q) => {
                return Err(TfjsError::Weight {
                    name: w.name.clone(),
                    why: format!("stored as {dtype} quantised to {q:?}, which is not read"),
                });
            }
        };
        let end = offset + count * stored;
        let bytes = bin.get(offset..end).ok_or(TfjsError::BinSize {
            expected: end,
            found: bin.len(),
        })?;
        if stored == 2 {
            floats.insert(
                w.name.clone(),
                FloatConst {
                    shape: w.shape.clone(),
                    f16_le: bytes.to_vec(),
                },
            );
        } else {
            let values = bytes
                .chunks_exact(4)
                .map(|b| i64::from(i32::from_le_bytes([b[0], b[1], b[2], b[3]])))
                .collect();
            ints.insert(
                w.name.clone(),
                IntConst {
                    shape: w.shape.clone(),
                    values,
                },
            );
        }
        offset = end;
    }
    if offset != bin.len() {
        return Err(TfjsError::BinSize {
            expected: offset,
            found: bin.len(),
        });
    }
    Ok((ints, floats))
}

/// A node's attributes in the graph's few kinds; type annotations (`T`, `dtype`, ...)
/// are dropped (the interpreter works in f32 and i64).
fn attrs(n: &TfNode) -> Result<BTreeMap<String, Attr>, TfjsError> {
    let mut out = BTreeMap::new();
    for (key, value) in &n.attr {
        let bad = || TfjsError::Attr {
            node: n.name.clone(),
            attr: key.clone(),
        };
        let attr = if let Some(b) = value.get("b") {
            Attr::Bool(b.as_bool().ok_or_else(bad)?)
        } else if let Some(f) = value.get("f") {
            Attr::Float(f.as_f64().ok_or_else(bad)?)
        } else if let Some(i) = value.get("i") {
            Attr::Int(json_int(i).ok_or_else(bad)?)
        } else if let Some(s) = value.get("s") {
            let text = s.as_str().ok_or_else(bad)?;
            Attr::Text(
                String::from_utf8(
                    base64::engine::general_purpose::STANDARD
                        .decode(text)
                        .map_err(|_| bad())?,
                )
                .map_err(|_| bad())?,
            )
        } else if let Some(list) = value.get("list") {
            match list.get("i") {
                Some(items) => Attr::Ints(
                    items
                        .as_array()
                        .ok_or_else(bad)?
                        .iter()
                        .map(json_int)
                        .collect::<Option<_>>()
                        .ok_or_else(bad)?,
                ),
                None => Attr::Ints(Vec::new()),
            }
        } else {
            // `type`, `shape`, `tensor`: what the op stores, not what it does.
            continue;
        };
        out.insert(key.clone(), attr);
    }
    Ok(out)
}

/// TF.js writes 64-bit integers as strings.
fn json_int(v: &serde_json::Value) -> Option<i64> {
    v.as_i64()
        .or_else(|| v.as_str().and_then(|s| s.parse().ok()))
}

fn placeholder_shape(attr: &BTreeMap<String, serde_json::Value>) -> Vec<usize> {
    attr.get("shape")
        .and_then(|s| s.get("shape"))
        .and_then(|s| s.get("dim"))
        .and_then(|d| d.as_array())
        .map(|dims| {
            dims.iter()
                .filter_map(|d| d.get("size").and_then(json_int))
                .map(|s| usize::try_from(s).unwrap_or(0))
                .collect()
        })
        .unwrap_or_default()
}

/// The outputs the signature names (without `:0`), in its order; otherwise the nodes no
/// other node reads.
fn outputs(model: &ModelJson, nodes: &[Node]) -> Vec<String> {
    let named: Vec<String> = model
        .signature
        .as_ref()
        .and_then(|s| s.get("outputs"))
        .and_then(|o| o.as_object())
        .map(|o| {
            let mut keys: Vec<String> = o
                .keys()
                .map(|k| k.trim_end_matches(":0").to_string())
                .collect();
            keys.sort();
            keys
        })
        .unwrap_or_default();
    if !named.is_empty() {
        return named;
    }
    let read: std::collections::HashSet<&str> = nodes
        .iter()
        .flat_map(|n| n.inputs.iter().map(|i| i.split(':').next().unwrap_or(i)))
        .collect();
    nodes
        .iter()
        .filter(|n| !read.contains(n.name.as_str()))
        .map(|n| n.name.clone())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    const MODEL: &str = r#"{
      "format": "graph-model",
      "signature": {"outputs": {"out:0": {"name": "out:0"}}},
      "modelTopology": {"node": [
        {"name": "x", "op": "Placeholder", "attr": {"shape": {"shape": {"dim": [{"size": "1"}, {"size": "2"}]}}, "dtype": {"type": "DT_FLOAT"}}},
        {"name": "b", "op": "Const", "attr": {}},
        {"name": "shape", "op": "Const", "attr": {}},
        {"name": "add", "op": "Add", "input": ["x", "b", "^shape"], "attr": {"T": {"type": "DT_FLOAT"}}},
        {"name": "out", "op": "LeakyRelu", "input": ["add"], "attr": {"alpha": {"f": 0.1}, "padding": {"s": "VkFMSUQ="}, "strides": {"list": {"i": ["1", "2"]}}}}
      ]},
      "weightsManifest": [{"paths": ["m.bin"], "weights": [
        {"name": "b", "shape": [2], "dtype": "float32", "quantization": {"dtype": "float16", "original_dtype": "float32"}},
        {"name": "shape", "shape": [2], "dtype": "int32"}
      ]}]
    }"#;

    fn bin() -> Vec<u8> {
        let mut bin = vec![0x00, 0x3c, 0x00, 0xc0]; // 1.0, -2.0 in float16
        bin.extend(1i32.to_le_bytes());
        bin.extend((-1i32).to_le_bytes());
        bin
    }

    #[test]
    fn a_small_model_converts() {
        let g = read(MODEL.as_bytes(), &bin(), BTreeMap::new()).expect("converts");
        assert_eq!(g.input, "x");
        assert_eq!(g.input_shape, vec![1, 2]);
        assert_eq!(g.outputs, vec!["out".to_string()]);
        assert_eq!(g.floats["b"].f16_le, vec![0x00, 0x3c, 0x00, 0xc0]);
        assert_eq!(g.ints["shape"].values, vec![1, -1]);
        let out = g.nodes.iter().find(|n| n.name == "out").expect("out");
        assert_eq!(out.attrs["alpha"], Attr::Float(0.1));
        assert_eq!(out.attrs["padding"], Attr::Text("VALID".into()));
        assert_eq!(out.attrs["strides"], Attr::Ints(vec![1, 2]));
        let add = g.nodes.iter().find(|n| n.name == "add").expect("add");
        assert_eq!(add.inputs, vec!["x".to_string(), "b".to_string()]);
    }

    #[test]
    fn a_short_or_long_weights_file_is_refused() {
        let mut short = bin();
        short.pop();
        let err = read(MODEL.as_bytes(), &short, BTreeMap::new()).expect_err("short");
        assert!(err.to_string().contains("bytes"), "{err}");
        let mut long = bin();
        long.push(0);
        assert!(read(MODEL.as_bytes(), &long, BTreeMap::new()).is_err());
        assert!(read(b"{", &bin(), BTreeMap::new()).is_err());
    }
}
