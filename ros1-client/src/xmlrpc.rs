//! XML-RPC as ROS 1's master and node APIs use it: calls and responses written and read,
//! with the values those APIs carry (integers, strings, booleans, doubles, arrays). Pure:
//! no I/O.

/// An XML-RPC value.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    Int(i32),
    Bool(bool),
    Double(f64),
    Str(String),
    Array(Vec<Value>),
    /// A struct, base64 or date: ROS's APIs use none where this client reads.
    Other,
}

/// What is wrong with an XML-RPC message.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum XmlRpcError {
    #[error("not XML: {0}")]
    Xml(String),
    #[error("not an XML-RPC {0}")]
    Shape(&'static str),
    #[error("bad {kind} value {text:?}")]
    BadValue { kind: &'static str, text: String },
    #[error("XML-RPC fault: {0}")]
    Fault(String),
}

impl Value {
    pub fn as_int(&self) -> Option<i32> {
        match self {
            Value::Int(i) => Some(*i),
            _ => None,
        }
    }

    pub fn as_str(&self) -> Option<&str> {
        match self {
            Value::Str(s) => Some(s),
            _ => None,
        }
    }

    pub fn as_array(&self) -> Option<&[Value]> {
        match self {
            Value::Array(a) => Some(a),
            _ => None,
        }
    }
}

impl From<&str> for Value {
    fn from(s: &str) -> Self {
        Value::Str(s.to_string())
    }
}

fn escape(text: &str, out: &mut String) {
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            c => out.push(c),
        }
    }
}

fn write_value(value: &Value, out: &mut String) {
    out.push_str("<value>");
    match value {
        Value::Int(i) => out.push_str(&format!("<i4>{i}</i4>")),
        Value::Bool(b) => out.push_str(&format!("<boolean>{}</boolean>", u8::from(*b))),
        Value::Double(d) => out.push_str(&format!("<double>{d}</double>")),
        Value::Str(s) => {
            out.push_str("<string>");
            escape(s, out);
            out.push_str("</string>");
        }
        Value::Array(items) => {
            out.push_str("<array><data>");
            for v in items {
                write_value(v, out);
            }
            out.push_str("</data></array>");
        }
        Value::Other => out.push_str("<string></string>"),
    }
    out.push_str("</value>");
}

/// A method call's XML.
pub fn method_call(method: &str, params: &[Value]) -> String {
    let mut out = String::from("<?xml version=\"1.0\"?><methodCall><methodName>");
    escape(method, &mut out);
    out.push_str("</methodName><params>");
    for p in params {
        out.push_str("<param>");
        write_value(p, &mut out);
        out.push_str("</param>");
    }
    out.push_str("</params></methodCall>");
    out
}

/// A response's XML, one value.
pub fn method_response(value: &Value) -> String {
    let mut out = String::from("<?xml version=\"1.0\"?><methodResponse><params><param>");
    write_value(value, &mut out);
    out.push_str("</param></params></methodResponse>");
    out
}

fn element<'a, 'i>(node: roxmltree::Node<'a, 'i>, name: &str) -> Option<roxmltree::Node<'a, 'i>> {
    node.children()
        .find(|c| c.is_element() && c.has_tag_name(name))
}

fn read_value(value: roxmltree::Node) -> Result<Value, XmlRpcError> {
    let Some(typed) = value.children().find(|c| c.is_element()) else {
        // An untyped value is a string.
        return Ok(Value::Str(value.text().unwrap_or("").to_string()));
    };
    let text = typed.text().unwrap_or("").trim();
    let bad = |kind| XmlRpcError::BadValue {
        kind,
        text: text.to_string(),
    };
    Ok(match typed.tag_name().name() {
        "i4" | "int" => Value::Int(text.parse().map_err(|_| bad("int"))?),
        "boolean" => Value::Bool(match text {
            "1" => true,
            "0" => false,
            _ => return Err(bad("boolean")),
        }),
        "double" => Value::Double(text.parse().map_err(|_| bad("double"))?),
        "string" => Value::Str(typed.text().unwrap_or("").to_string()),
        "array" => {
            let data = element(typed, "data").ok_or(XmlRpcError::Shape("array"))?;
            Value::Array(
                data.children()
                    .filter(|c| c.is_element() && c.has_tag_name("value"))
                    .map(read_value)
                    .collect::<Result<_, _>>()?,
            )
        }
        _ => Value::Other,
    })
}

fn parse(xml: &str) -> Result<roxmltree::Document<'_>, XmlRpcError> {
    roxmltree::Document::parse(xml).map_err(|e| XmlRpcError::Xml(e.to_string()))
}

/// A response's one value, or its fault as an error.
pub fn parse_response(xml: &str) -> Result<Value, XmlRpcError> {
    let doc = parse(xml)?;
    let root = doc.root_element();
    if !root.has_tag_name("methodResponse") {
        return Err(XmlRpcError::Shape("response"));
    }
    if let Some(fault) = element(root, "fault") {
        let text = element(fault, "value")
            .map(|v| format!("{:?}", read_value(v)))
            .unwrap_or_default();
        return Err(XmlRpcError::Fault(text));
    }
    let value = element(root, "params")
        .and_then(|p| element(p, "param"))
        .and_then(|p| element(p, "value"))
        .ok_or(XmlRpcError::Shape("response"))?;
    read_value(value)
}

/// A call's method name and parameters.
pub fn parse_call(xml: &str) -> Result<(String, Vec<Value>), XmlRpcError> {
    let doc = parse(xml)?;
    let root = doc.root_element();
    if !root.has_tag_name("methodCall") {
        return Err(XmlRpcError::Shape("call"));
    }
    let method = element(root, "methodName")
        .and_then(|m| m.text())
        .ok_or(XmlRpcError::Shape("call"))?
        .trim()
        .to_string();
    let params = match element(root, "params") {
        Some(p) => p
            .children()
            .filter(|c| c.is_element() && c.has_tag_name("param"))
            .map(|p| element(p, "value").ok_or(XmlRpcError::Shape("call")))
            .map(|v| v.and_then(read_value))
            .collect::<Result<_, _>>()?,
        None => Vec::new(),
    };
    Ok((method, params))
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn a_call_reads_back_as_written() {
        let params = vec![
            Value::from("/robot_agent"),
            Value::from("/miro/a<b>&c"),
            Value::Array(vec![Value::Array(vec![Value::from("TCPROS")])]),
            Value::Int(-3),
            Value::Bool(true),
            Value::Double(0.25),
        ];
        let xml = method_call("requestTopic", &params);
        assert_eq!(parse_call(&xml).unwrap(), ("requestTopic".into(), params));
    }

    #[test]
    fn responses_as_rosmaster_writes_them() {
        // Python's xmlrpc writes untyped strings and <int>.
        let xml = "<?xml version='1.0'?>\n<methodResponse>\n<params>\n<param>\n<value><array><data>\n\
                   <value><int>1</int></value>\n<value><string>Subscribed to [/a]</string></value>\n\
                   <value><array><data>\n<value>http://host:4567/</value>\n</data></array></value>\n\
                   </data></array></value>\n</param>\n</params>\n</methodResponse>\n";
        let v = parse_response(xml).unwrap();
        let a = v.as_array().unwrap();
        assert_eq!(a[0].as_int(), Some(1));
        assert_eq!(a[1].as_str(), Some("Subscribed to [/a]"));
        assert_eq!(a[2], Value::Array(vec![Value::from("http://host:4567/")]));
        assert_eq!(
            parse_response(&method_response(&Value::Int(7))).unwrap(),
            Value::Int(7)
        );
    }

    #[test]
    fn faults_and_garbage_are_errors() {
        let fault =
            "<methodResponse><fault><value><struct></struct></value></fault></methodResponse>";
        assert!(matches!(parse_response(fault), Err(XmlRpcError::Fault(_))));
        assert!(matches!(parse_response("<html>"), Err(XmlRpcError::Xml(_))));
        assert_eq!(
            parse_response("<methodCall/>"),
            Err(XmlRpcError::Shape("response"))
        );
        assert!(matches!(
            parse_response(
                "<methodResponse><params><param><value><int>x</int></value></param></params></methodResponse>"
            ),
            Err(XmlRpcError::BadValue { kind: "int", .. })
        ));
        assert!(parse_call("<methodCall><params/></methodCall>").is_err());
    }
}
