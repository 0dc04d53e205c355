//! The forward pass: the graph's ops, in data order, over candle tensors on the CPU.
//!
//! Only the ops the teacher's graph uses are known; a graph with any other op is refused
//! when it is loaded, not when it runs. The graph came from ONNX through onnx-tf, so its
//! convolutions are NHWC between transposes; the transposes are kept (they are views), and
//! each convolution and pooling runs in candle's NCHW.

use crate::graph::{Attr, Graph, Node};
use candle_core::{DType, Device, Tensor};
use std::collections::HashMap;
use thiserror::Error;

/// Why the graph cannot be loaded or run.
#[derive(Debug, Error)]
pub enum RunError {
    #[error("node {node:?}: op {op:?} is not one the teacher runs")]
    UnknownOp { node: String, op: String },
    #[error("node {node:?}: {why}")]
    Node { node: String, why: String },
    #[error("the input is {found:?}, the graph takes {expected:?}")]
    InputShape {
        expected: Vec<usize>,
        found: Vec<usize>,
    },
    #[error("tensor arithmetic: {0}")]
    Tensor(#[from] candle_core::Error),
}

const OPS: &[&str] = &[
    "Placeholder",
    "Identity",
    "Pad",
    "PadV2",
    "Transpose",
    "Conv2D",
    "Add",
    "AddV2",
    "LeakyRelu",
    "MaxPool",
    "ConcatV2",
    "ResizeBilinear",
    "SplitV",
    "Sigmoid",
    "Reshape",
    "SparseToDense",
];

/// A float tensor as it lies in memory, with the order of its axes: the graph's tensor is
/// `data.permute(perm)` (its axis `i` is the data's axis `perm[i]`).
#[derive(Debug, Clone)]
struct Laid {
    data: Tensor,
    perm: Vec<usize>,
}

impl Laid {
    fn plain(data: Tensor) -> Self {
        let perm = (0..data.rank()).collect();
        Laid { data, perm }
    }

    fn is_plain(&self) -> bool {
        self.perm.iter().enumerate().all(|(i, p)| i == *p)
    }

    /// The graph's tensor (a view when the order differs).
    fn logical(&self) -> Result<Tensor, candle_core::Error> {
        if self.is_plain() {
            Ok(self.data.clone())
        } else {
            self.data.permute(self.perm.clone())
        }
    }

    /// The same axis order over other data of the same layout.
    fn with(&self, data: Tensor) -> Self {
        Laid {
            data,
            perm: self.perm.clone(),
        }
    }
}

#[derive(Debug, Clone)]
enum Value {
    Float(Laid),
    Int { shape: Vec<usize>, values: Vec<i64> },
}

/// Where an input comes from: a step's k-th output, or a constant.
#[derive(Debug, Clone)]
enum Source {
    Step { step: usize, output: usize },
    Const(usize),
}

#[derive(Debug)]
struct Step {
    node: Node,
    inputs: Vec<Source>,
    /// A convolution's constant filter as a matrix `[kh * kw * cin, cout]` (HWIO flattened).
    filter: Option<Filter>,
}

/// The graph made ready to run: constants as tensors, steps in data order.
#[derive(Debug)]
pub struct Program {
    steps: Vec<Step>,
    consts: Vec<Value>,
    outputs: Vec<Source>,
    input_shape: Vec<usize>,
}

fn node_err(node: &Node, why: impl Into<String>) -> RunError {
    RunError::Node {
        node: node.name.clone(),
        why: why.into(),
    }
}

impl Program {
    /// The graph's steps in data order from its input to its outputs (nodes no output
    /// needs are left out); every op checked.
    pub fn new(graph: &Graph) -> Result<Self, RunError> {
        let device = Device::Cpu;
        let by_name: HashMap<&str, &Node> =
            graph.nodes.iter().map(|n| (n.name.as_str(), n)).collect();
        let mut consts = Vec::new();
        let mut const_index: HashMap<String, usize> = HashMap::new();
        for (name, c) in &graph.floats {
            let t = Tensor::from_raw_buffer(&c.f16_le, DType::F16, &c.shape, &device)?
                .to_dtype(DType::F32)?;
            const_index.insert(name.clone(), consts.len());
            consts.push(Value::Float(Laid::plain(t)));
        }
        for (name, c) in &graph.ints {
            const_index.insert(name.clone(), consts.len());
            consts.push(Value::Int {
                shape: c.shape.clone(),
                values: c.values.clone(),
            });
        }
        // Depth-first from the outputs: each node after the nodes it reads.
        let mut order: Vec<&Node> = Vec::new();
        let mut state: HashMap<&str, u8> = HashMap::new(); // 1 visiting, 2 done
        let mut stack: Vec<(&str, bool)> = graph
            .outputs
            .iter()
            .rev()
            .map(|o| (o.as_str(), false))
            .collect();
        while let Some((name, expanded)) = stack.pop() {
            let Some(node) = by_name.get(name) else {
                continue; // a constant
            };
            if expanded {
                state.insert(name, 2);
                order.push(node);
                continue;
            }
            match state.get(name) {
                Some(2) => continue,
                Some(_) => return Err(node_err(node, "the graph has a cycle through it")),
                None => {}
            }
            if !OPS.contains(&node.op.as_str()) {
                return Err(RunError::UnknownOp {
                    node: node.name.clone(),
                    op: node.op.clone(),
                });
            }
            state.insert(name, 1);
            stack.push((name, true));
            for input in node.inputs.iter().rev() {
                let base = input.split(':').next().unwrap_or(input);
                if state.get(base) != Some(&2) {
                    stack.push((base, false));
                }
            }
        }
        let mut step_index: HashMap<&str, usize> = HashMap::new();
        let mut steps = Vec::new();
        for node in order {
            let inputs = node
                .inputs
                .iter()
                .map(|i| source(i, &step_index, &const_index))
                .collect::<Option<Vec<_>>>()
                .ok_or_else(|| node_err(node, "reads a value made by no node"))?;
            let filter = match (node.op.as_str(), inputs.get(1)) {
                ("Conv2D", Some(Source::Const(c))) => match &consts[*c] {
                    Value::Float(Laid { data: hwio, .. }) if hwio.rank() == 4 => {
                        let (kh, kw, cin, cout) = hwio.dims4()?;
                        Some(Filter {
                            kh,
                            kw,
                            cin,
                            matrix: hwio.reshape((kh * kw * cin, cout))?,
                        })
                    }
                    _ => return Err(node_err(node, "its filter is not a 4-D float constant")),
                },
                ("Conv2D", _) => return Err(node_err(node, "its filter is not a constant")),
                _ => None,
            };
            step_index.insert(node.name.as_str(), steps.len());
            steps.push(Step {
                node: node.clone(),
                inputs,
                filter,
            });
        }
        let outputs = graph
            .outputs
            .iter()
            .map(|o| source(o, &step_index, &const_index))
            .collect::<Option<Vec<_>>>()
            .ok_or_else(|| RunError::Node {
                node: "(outputs)".into(),
                why: "an output is made by no node".into(),
            })?;
        Ok(Program {
            steps,
            consts,
            outputs,
            input_shape: graph.input_shape.clone(),
        })
    }

    /// The input's shape (NCHW).
    pub fn input_shape(&self) -> &[usize] {
        &self.input_shape
    }

    /// The outputs for one input tensor, in the graph's output order.
    pub fn run(&self, input: &Tensor) -> Result<Vec<Tensor>, RunError> {
        if input.dims() != self.input_shape.as_slice() {
            return Err(RunError::InputShape {
                expected: self.input_shape.clone(),
                found: input.dims().to_vec(),
            });
        }
        let mut values: Vec<Vec<Value>> = Vec::with_capacity(self.steps.len());
        for step in &self.steps {
            let args: Vec<&Value> = step
                .inputs
                .iter()
                .map(|s| self.value(s, &values))
                .collect::<Result<_, _>>()?;
            let out = eval(step, &args, input).map_err(|e| match e {
                RunError::Tensor(t) => node_err(&step.node, t.to_string()),
                other => other,
            })?;
            values.push(out);
        }
        self.outputs
            .iter()
            .map(|s| match self.value(s, &values)? {
                Value::Float(t) => Ok(t.logical()?),
                Value::Int { .. } => Err(RunError::Node {
                    node: "(outputs)".into(),
                    why: "an output is an integer tensor".into(),
                }),
            })
            .collect()
    }

    fn value<'a>(&'a self, s: &Source, values: &'a [Vec<Value>]) -> Result<&'a Value, RunError> {
        match s {
            Source::Const(c) => Ok(&self.consts[*c]),
            Source::Step { step, output } => values
                .get(*step)
                .and_then(|v| v.get(*output))
                .ok_or_else(|| RunError::Node {
                    node: self.steps[*step].node.name.clone(),
                    why: format!("has no output {output}"),
                }),
        }
    }
}

fn source(
    name: &str,
    steps: &HashMap<&str, usize>,
    consts: &HashMap<String, usize>,
) -> Option<Source> {
    let (base, output) = match name.split_once(':') {
        Some((b, k)) => (b, k.parse().ok()?),
        None => (name, 0),
    };
    if let Some(step) = steps.get(base) {
        return Some(Source::Step {
            step: *step,
            output,
        });
    }
    consts.get(base).map(|c| Source::Const(*c))
}

fn float<'a>(node: &Node, v: &'a Value) -> Result<&'a Laid, RunError> {
    match v {
        Value::Float(t) => Ok(t),
        Value::Int { .. } => Err(node_err(node, "expected a float tensor, got integers")),
    }
}

fn ints<'a>(node: &Node, v: &'a Value) -> Result<&'a [i64], RunError> {
    match v {
        Value::Int { values, .. } => Ok(values),
        Value::Float(_) => Err(node_err(node, "expected integers, got a float tensor")),
    }
}

fn arg<'a>(node: &Node, args: &[&'a Value], k: usize) -> Result<&'a Value, RunError> {
    args.get(k)
        .copied()
        .ok_or_else(|| node_err(node, format!("has no input {k}")))
}

fn attr_ints<'a>(node: &'a Node, key: &str) -> Result<&'a [i64], RunError> {
    match node.attrs.get(key) {
        Some(Attr::Ints(v)) => Ok(v),
        _ => Err(node_err(node, format!("attribute {key:?} is missing"))),
    }
}

fn attr_text<'a>(node: &'a Node, key: &str) -> &'a str {
    match node.attrs.get(key) {
        Some(Attr::Text(s)) => s,
        _ => "",
    }
}

fn usize_of(node: &Node, v: i64) -> Result<usize, RunError> {
    usize::try_from(v).map_err(|_| node_err(node, format!("negative size {v}")))
}

/// An axis, negative counting from the end.
fn axis(node: &Node, v: i64, rank: usize) -> Result<usize, RunError> {
    let a = if v < 0 { v + rank as i64 } else { v };
    usize::try_from(a)
        .ok()
        .filter(|a| *a < rank)
        .ok_or_else(|| node_err(node, format!("axis {v} of a rank-{rank} tensor")))
}

fn eval(step: &Step, args: &[&Value], input: &Tensor) -> Result<Vec<Value>, RunError> {
    let node = &step.node;
    let x = || -> Result<&Laid, RunError> { float(node, arg(node, args, 0)?) };
    let one = |t: Laid| Ok(vec![Value::Float(t)]);
    let plain = |t: Tensor| Ok(vec![Value::Float(Laid::plain(t))]);
    match node.op.as_str() {
        "Placeholder" => plain(input.clone()),
        "Identity" => Ok(vec![arg(node, args, 0)?.clone()]),
        "Transpose" => {
            let t = x()?;
            let perm: Vec<usize> = ints(node, arg(node, args, 1)?)?
                .iter()
                .map(|p| usize_of(node, *p))
                .collect::<Result<_, _>>()?;
            if perm.len() != t.perm.len() || perm.iter().any(|p| *p >= t.perm.len()) {
                return Err(node_err(node, "the permutation does not fit the tensor"));
            }
            // Axis i of the result is axis perm[i] of the input: no data moves.
            let perm = perm.iter().map(|p| t.perm[*p]).collect();
            one(Laid {
                data: t.data.clone(),
                perm,
            })
        }
        "Pad" | "PadV2" => {
            let pads = ints(node, arg(node, args, 1)?)?;
            let value = if node.op == "PadV2" {
                float(node, arg(node, args, 2)?)?
                    .data
                    .flatten_all()?
                    .to_vec1::<f32>()?
                    .first()
                    .copied()
                    .unwrap_or(0.0)
            } else {
                0.0
            };
            let t = x()?;
            if pads.len() != 2 * t.perm.len() {
                return Err(node_err(node, "paddings do not match the tensor's rank"));
            }
            // The graph's axis l lies as the data's axis perm[l].
            let mut physical = vec![0i64; pads.len()];
            for (l, p) in t.perm.iter().enumerate() {
                physical[2 * p] = pads[2 * l];
                physical[2 * p + 1] = pads[2 * l + 1];
            }
            one(t.with(pad(node, &t.data, &physical, value)?))
        }
        "Conv2D" => {
            let filter = step
                .filter
                .as_ref()
                .ok_or_else(|| node_err(node, "no filter"))?;
            let strides = attr_ints(node, "strides")?;
            let dilations = attr_ints(node, "dilations").unwrap_or(&[1, 1, 1, 1]);
            if attr_text(node, "padding") != "VALID"
                || attr_text(node, "data_format") != "NHWC"
                || strides.len() != 4
                || strides[1] != strides[2]
                || dilations.iter().any(|d| *d != 1)
            {
                return Err(node_err(
                    node,
                    "only NHWC convolutions with explicit padding, square strides and no dilation run",
                ));
            }
            plain(conv_nhwc(
                &x()?.logical()?,
                filter,
                usize_of(node, strides[1])?,
            )?)
        }
        "Add" | "AddV2" => match (arg(node, args, 0)?, arg(node, args, 1)?) {
            (Value::Float(a), Value::Float(b)) => {
                let rank = a.perm.len();
                if a.perm == b.perm && a.data.dims() == b.data.dims() {
                    one(a.with((&a.data + &b.data)?))
                } else if b.perm.len() == 1 && a.perm.last() == Some(&(rank - 1)) {
                    // A bias over the last axis, which lies last in memory too.
                    one(a.with(a.data.broadcast_add(&b.data)?))
                } else {
                    plain(a.logical()?.broadcast_add(&b.logical()?)?)
                }
            }
            (
                Value::Int {
                    shape: sa,
                    values: a,
                },
                Value::Int { values: b, .. },
            ) => {
                let values = if b.len() == a.len() {
                    a.iter().zip(b).map(|(p, q)| p + q).collect()
                } else if b.len() == 1 {
                    a.iter().map(|p| p + b[0]).collect()
                } else {
                    return Err(node_err(node, "integer add of unlike shapes"));
                };
                Ok(vec![Value::Int {
                    shape: sa.clone(),
                    values,
                }])
            }
            _ => Err(node_err(node, "adds a float tensor to integers")),
        },
        "LeakyRelu" => {
            let alpha = match node.attrs.get("alpha") {
                Some(Attr::Float(a)) => *a,
                _ => 0.2,
            };
            let t = x()?;
            one(t.with(t.data.maximum(&(&t.data * alpha)?)?))
        }
        "MaxPool" => {
            let k = attr_ints(node, "ksize")?;
            let s = attr_ints(node, "strides")?;
            if attr_text(node, "padding") != "VALID" || k.len() != 4 || s.len() != 4 {
                return Err(node_err(
                    node,
                    "only NHWC pooling with explicit padding runs",
                ));
            }
            // Candle pools NCHW: an NHWC tensor lying as NCHW is pooled where it lies.
            const NCHW_AS_NHWC: [usize; 4] = [0, 2, 3, 1];
            let t = x()?;
            let nchw = if t.perm == NCHW_AS_NHWC {
                t.data.clone()
            } else {
                t.logical()?.permute((0, 3, 1, 2))?.contiguous()?
            };
            let out = nchw.max_pool2d_with_stride(
                (usize_of(node, k[1])?, usize_of(node, k[2])?),
                (usize_of(node, s[1])?, usize_of(node, s[2])?),
            )?;
            one(Laid {
                data: out,
                perm: NCHW_AS_NHWC.to_vec(),
            })
        }
        "ConcatV2" => {
            let (last, parts) = args
                .split_last()
                .ok_or_else(|| node_err(node, "concatenates nothing"))?;
            let parts: Vec<&Laid> = parts
                .iter()
                .map(|v| float(node, v))
                .collect::<Result<_, _>>()?;
            let first = parts
                .first()
                .ok_or_else(|| node_err(node, "concatenates nothing"))?;
            let a = axis(
                node,
                ints(node, last)?.first().copied().unwrap_or(0),
                first.perm.len(),
            )?;
            if parts.iter().all(|p| p.perm == first.perm) {
                let data: Vec<&Tensor> = parts.iter().map(|p| &p.data).collect();
                one(first.with(Tensor::cat(&data, first.perm[a])?))
            } else {
                let logical: Vec<Tensor> = parts
                    .iter()
                    .map(|p| p.logical())
                    .collect::<Result<_, _>>()?;
                plain(Tensor::cat(&logical, a)?)
            }
        }
        "ResizeBilinear" => {
            let size = ints(node, arg(node, args, 1)?)?;
            if size.len() != 2 {
                return Err(node_err(node, "the size is not [height, width]"));
            }
            let half_pixel = matches!(node.attrs.get("half_pixel_centers"), Some(Attr::Bool(true)));
            let align = matches!(node.attrs.get("align_corners"), Some(Attr::Bool(true)));
            if align || !half_pixel {
                return Err(node_err(node, "only half-pixel-centred resizing runs"));
            }
            plain(resize_bilinear(
                &x()?.logical()?,
                usize_of(node, size[0])?,
                usize_of(node, size[1])?,
            )?)
        }
        "SplitV" => {
            let t = x()?;
            let sizes = ints(node, arg(node, args, 1)?)?;
            let a = axis(
                node,
                ints(node, arg(node, args, 2)?)?
                    .first()
                    .copied()
                    .unwrap_or(0),
                t.perm.len(),
            )?;
            let physical = t.perm[a];
            let mut start = 0;
            let mut out = Vec::new();
            for s in sizes {
                let len = if *s < 0 {
                    t.data.dim(physical)? - start
                } else {
                    usize_of(node, *s)?
                };
                out.push(Value::Float(t.with(t.data.narrow(physical, start, len)?)));
                start += len;
            }
            Ok(out)
        }
        "Sigmoid" => {
            let t = x()?;
            one(t.with(((t.data.neg()?.exp()? + 1.0)?).recip()?))
        }
        "Reshape" => {
            let t = x()?.logical()?;
            let want = ints(node, arg(node, args, 1)?)?;
            let known: usize = want
                .iter()
                .filter(|d| **d >= 0)
                .map(|d| usize::try_from(*d).unwrap_or(0))
                .product();
            let shape: Vec<usize> = want
                .iter()
                .map(|d| {
                    if *d < 0 {
                        t.elem_count() / known.max(1)
                    } else {
                        usize::try_from(*d).unwrap_or(0)
                    }
                })
                .collect();
            plain(t.reshape(shape)?)
        }
        "SparseToDense" => {
            // The graph's sparse tensors are all empty (shape arithmetic left over from
            // ONNX): the dense tensor is the default value everywhere.
            let indices = arg(node, args, 0)?;
            let shape = ints(node, arg(node, args, 1)?)?;
            let default = ints(node, arg(node, args, 3)?)?
                .first()
                .copied()
                .unwrap_or(0);
            if let Value::Int { values, .. } = indices
                && !values.is_empty()
            {
                return Err(node_err(node, "only empty sparse tensors run"));
            }
            let shape: Vec<usize> = shape
                .iter()
                .map(|d| usize_of(node, *d))
                .collect::<Result<_, _>>()?;
            let n = shape.iter().product();
            Ok(vec![Value::Int {
                shape,
                values: vec![default; n],
            }])
        }
        other => Err(RunError::UnknownOp {
            node: node.name.clone(),
            op: other.to_string(),
        }),
    }
}

/// A convolution's filter as one matrix.
#[derive(Debug)]
struct Filter {
    kh: usize,
    kw: usize,
    cin: usize,
    /// `[kh * kw * cin, cout]`.
    matrix: Tensor,
}

/// A convolution without padding over an NHWC tensor: the windows copied into rows
/// (each a run of whole pixels, channels innermost) and one matrix product with the
/// filter. The output is NHWC and contiguous.
fn conv_nhwc(x: &Tensor, f: &Filter, stride: usize) -> Result<Tensor, RunError> {
    let (n, h, w, c) = x.dims4()?;
    if c != f.cin || h < f.kh || w < f.kw || stride == 0 {
        return Err(RunError::Tensor(candle_core::Error::Msg(format!(
            "a {h}x{w}x{c} input to a {}x{}x{} filter",
            f.kh, f.kw, f.cin
        ))));
    }
    let oh = (h - f.kh) / stride + 1;
    let ow = (w - f.kw) / stride + 1;
    let cout = f.matrix.dim(1)?;
    let rows = n * oh * ow;
    let cols = if f.kh == 1 && f.kw == 1 && stride == 1 {
        x.contiguous()?.reshape((rows, c))?
    } else {
        let data = x.contiguous()?.flatten_all()?.to_vec1::<f32>()?;
        let k = f.kh * f.kw * c;
        let mut cols = vec![0f32; rows * k];
        for (r, row) in cols.chunks_exact_mut(k).enumerate() {
            let (b, rest) = (r / (oh * ow), r % (oh * ow));
            let (oy, ox) = (rest / ow, rest % ow);
            for ky in 0..f.kh {
                let y = oy * stride + ky;
                let src = ((b * h + y) * w + ox * stride) * c;
                let dst = ky * f.kw * c;
                // The window's row of kw pixels is one contiguous run.
                row[dst..dst + f.kw * c].copy_from_slice(&data[src..src + f.kw * c]);
            }
        }
        Tensor::from_vec(cols, (rows, k), x.device())?
    };
    Ok(cols.matmul(&f.matrix)?.reshape((n, oh, ow, cout))?)
}

/// Constant padding, `pads` `[rank, 2]` (before, after per axis).
fn pad(node: &Node, t: &Tensor, pads: &[i64], value: f32) -> Result<Tensor, RunError> {
    if pads.len() != 2 * t.rank() {
        return Err(node_err(node, "paddings do not match the tensor's rank"));
    }
    let mut out = t.clone();
    for (dim, p) in pads.chunks_exact(2).enumerate() {
        let (before, after) = (usize_of(node, p[0])?, usize_of(node, p[1])?);
        if before == 0 && after == 0 {
            continue;
        }
        if value == 0.0 {
            out = out.pad_with_zeros(dim, before, after)?;
        } else {
            let mut parts = Vec::new();
            let mut shape = out.dims().to_vec();
            if before > 0 {
                shape[dim] = before;
                parts.push(Tensor::full(value, shape.clone(), out.device())?);
            }
            parts.push(out.clone());
            if after > 0 {
                shape[dim] = after;
                parts.push(Tensor::full(value, shape.clone(), out.device())?);
            }
            out = Tensor::cat(&parts, dim)?;
        }
    }
    Ok(out)
}

/// TensorFlow's bilinear resize of an NHWC tensor with half-pixel centres.
fn resize_bilinear(t: &Tensor, out_h: usize, out_w: usize) -> Result<Tensor, candle_core::Error> {
    let (n, h, w, c) = t.dims4()?;
    let data = t.contiguous()?.flatten_all()?.to_vec1::<f32>()?;
    let taps = |out: usize, inp: usize| -> Vec<(usize, usize, f32)> {
        let scale = inp as f32 / out as f32;
        (0..out)
            .map(|i| {
                let src = (i as f32 + 0.5) * scale - 0.5;
                let fl = src.floor();
                let lower = (fl.max(0.0) as usize).min(inp - 1);
                let upper = (src.ceil().max(0.0) as usize).min(inp - 1);
                (lower, upper, src - fl)
            })
            .collect()
    };
    let ys = taps(out_h, h);
    let xs = taps(out_w, w);
    let mut out = vec![0f32; n * out_h * out_w * c];
    for b in 0..n {
        for (oy, &(y0, y1, fy)) in ys.iter().enumerate() {
            for (ox, &(x0, x1, fx)) in xs.iter().enumerate() {
                let at = |y: usize, x: usize, k: usize| data[((b * h + y) * w + x) * c + k];
                let o = ((b * out_h + oy) * out_w + ox) * c;
                for k in 0..c {
                    let top = at(y0, x0, k) + (at(y0, x1, k) - at(y0, x0, k)) * fx;
                    let bottom = at(y1, x0, k) + (at(y1, x1, k) - at(y1, x0, k)) * fx;
                    out[o + k] = top + (bottom - top) * fy;
                }
            }
        }
    }
    Tensor::from_vec(out, (n, out_h, out_w, c), t.device())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn halving_by_resize_averages_pairs_and_doubling_interpolates() {
        let t = Tensor::from_vec(vec![0f32, 2.0, 4.0, 6.0], (1, 1, 4, 1), &Device::Cpu)
            .expect("tensor");
        let half = resize_bilinear(&t, 1, 2).expect("resize");
        assert_eq!(
            half.flatten_all()
                .and_then(|v| v.to_vec1::<f32>())
                .expect("values"),
            vec![1.0, 5.0]
        );
        let double = resize_bilinear(&t, 1, 8).expect("resize");
        let v = double
            .flatten_all()
            .and_then(|v| v.to_vec1::<f32>())
            .expect("values");
        // Half-pixel centres: the first output sits a quarter pixel left of the first input.
        assert_eq!(v[0], 0.0);
        assert_eq!(v[1], 0.5);
        assert_eq!(v[2], 1.5);
        assert_eq!(v[7], 6.0);
    }
}
