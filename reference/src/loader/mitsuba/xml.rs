//! Mitsuba 3's XML scene format read into a tree of [`Object`]s: the
//! file's structure with `default`, `$name` substitution, `include`,
//! `path`, `id`/`ref` and `alias` resolved, every transform element
//! composed into one matrix, and every value parsed, each with the place
//! in its file. What the objects mean is [`super::scene`]'s business.
//!
//! The XML itself is parsed by `roxmltree`. The format's rules follow
//! Mitsuba 3's documentation ("Scene format", "File format" of the
//! reference manual) and its parser (src/core/xml.cpp), read for the
//! rules only:
//! - scene versions 2.x and 3.x are read (0.x files use other names and
//!   are refused with a line saying so);
//! - `<default name value>` sets a parameter unless the command line
//!   (`-D name=value`) set it; `$name` in any attribute is replaced by the
//!   parameter's value;
//! - `<include filename>` splices the children of another `<scene>` file
//!   in (relative paths resolved against the including file's folder and
//!   the `path` folders); an `id` defined twice is an error;
//! - transform elements compose left to right: each new one is applied
//!   after those before it (`M = op · M`).

use glam::{DMat3, DMat4, DVec3};
use std::collections::HashMap;
use std::fmt;
use std::path::{Path, PathBuf};
use std::rc::Rc;

/// Where something is in a scene file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Location {
    pub file: PathBuf,
    pub line: u32,
    pub column: u32,
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}:{}", self.file.display(), self.line, self.column)
    }
}

/// An error in a scene file, at a place.
#[derive(Clone, Debug, PartialEq)]
pub struct XmlError {
    pub at: Location,
    pub message: String,
}

impl fmt::Display for XmlError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.at, self.message)
    }
}

/// A spectrum as the file wrote it.
#[derive(Clone, Debug, PartialEq)]
pub enum Spectrum {
    /// One value at every wavelength.
    Uniform(f64),
    /// `wavelength:value` pairs (nanometres), ascending.
    Pairs(Vec<(f64, f64)>),
}

/// A property's value.
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    Float(f64),
    Integer(i64),
    Boolean(bool),
    String(String),
    Rgb(DVec3),
    Spectrum(Spectrum),
    Point(DVec3),
    Vector(DVec3),
    Transform(DMat4),
}

impl Value {
    /// The element name that writes this kind of value.
    pub fn kind(&self) -> &'static str {
        match self {
            Value::Float(_) => "float",
            Value::Integer(_) => "integer",
            Value::Boolean(_) => "boolean",
            Value::String(_) => "string",
            Value::Rgb(_) => "rgb",
            Value::Spectrum(_) => "spectrum",
            Value::Point(_) => "point",
            Value::Vector(_) => "vector",
            Value::Transform(_) => "transform",
        }
    }
}

/// A named value of an object.
#[derive(Clone, Debug, PartialEq)]
pub struct Property {
    pub name: String,
    pub value: Value,
    pub at: Location,
}

/// A nested object: its `name` attribute (which parameter of the parent it
/// fills, when given) and the object, shared when it came by `ref`.
#[derive(Clone, Debug, PartialEq)]
pub struct Child {
    pub name: Option<String>,
    pub object: Rc<Object>,
}

/// A plugin instance: `<shape type="obj" id="...">...</shape>`.
#[derive(Clone, Debug, PartialEq)]
pub struct Object {
    /// The element: `scene`, `shape`, `bsdf`, `emitter`, `sensor`, `film`,
    /// `rfilter`, `sampler`, `integrator`, `texture`, `medium`, `phase`,
    /// `volume`, `spectrum` (a spectrum plugin), ...
    pub tag: String,
    /// The plugin (`type`); empty for `scene`.
    pub kind: String,
    pub id: Option<String>,
    pub props: Vec<Property>,
    pub children: Vec<Child>,
    pub at: Location,
}

impl Object {
    /// `shape "obj"` and where: how errors name an object.
    pub fn describe(&self) -> String {
        match &self.id {
            Some(id) => format!("{} \"{}\" (id \"{id}\")", self.tag, self.kind),
            None => format!("{} \"{}\"", self.tag, self.kind),
        }
    }
}

/// The elements that are objects (plugins) rather than values.
const OBJECT_TAGS: &[&str] = &[
    "shape",
    "bsdf",
    "emitter",
    "sensor",
    "film",
    "rfilter",
    "sampler",
    "integrator",
    "texture",
    "medium",
    "phase",
    "volume",
];

/// The deepest chain of includes read (a file including itself, directly
/// or not, is caught sooner; this bounds a chain of distinct files).
const MAX_INCLUDE_DEPTH: usize = 32;

/// The parser's state over one scene and its includes.
struct Reader {
    /// Parameters: the command line's first (they win), then defaults.
    params: HashMap<String, String>,
    /// Command-line parameters, which `default` does not override.
    defined: Vec<String>,
    /// Folders searched for relative file names (`path` elements and the
    /// scene file's own folder), in the order Mitsuba searches them: the
    /// latest `path` first.
    search: Vec<PathBuf>,
    ids: HashMap<String, Rc<Object>>,
    /// The include chain, to refuse cycles.
    open: Vec<PathBuf>,
}

/// A parsed scene: the root object and the folders relative file names
/// are resolved against.
#[derive(Clone, Debug)]
pub struct Document {
    pub root: Object,
    pub search: Vec<PathBuf>,
}

impl Document {
    /// Resolves a file name the scene gave (a `filename` property) as
    /// Mitsuba does: an absolute path as it is, else the first of the
    /// search folders (the latest `path` first, the scene's folder last)
    /// where it exists; where none has it, relative to the scene's folder.
    pub fn resolve(&self, name: &str) -> PathBuf {
        let p = Path::new(name);
        if p.is_absolute() {
            return p.to_path_buf();
        }
        for dir in &self.search {
            let candidate = dir.join(p);
            if candidate.exists() {
                return candidate;
            }
        }
        self.search
            .last()
            .map(|d| d.join(p))
            .unwrap_or_else(|| p.to_path_buf())
    }
}

/// Reads a scene file with `-D` parameters (`(name, value)` pairs).
pub fn parse_file(path: &Path, defines: &[(String, String)]) -> Result<Document, XmlError> {
    let mut reader = Reader::new(path, defines);
    let root = reader.read_file(path, true)?;
    reader.search.reverse();
    Ok(Document {
        root,
        search: reader.search,
    })
}

/// Reads scene text (as if from `path`, for errors and relative names).
pub fn parse_text(
    text: &str,
    path: &Path,
    defines: &[(String, String)],
) -> Result<Document, XmlError> {
    let mut reader = Reader::new(path, defines);
    reader.open.push(path.to_path_buf());
    let root = reader.read_text(text, path, true)?;
    reader.search.reverse();
    Ok(Document {
        root,
        search: reader.search,
    })
}

fn at_file(path: &Path) -> Location {
    Location {
        file: path.to_path_buf(),
        line: 1,
        column: 1,
    }
}

/// The largest scene file read (a bound against reading a wrong, huge
/// file as XML; the largest scene of Mitsuba's test data is 5 KiB and
/// real scenes keep their geometry in mesh files).
const MAX_XML_BYTES: u64 = 256 << 20;

impl Reader {
    /// A reader of the scene at `path` with the command line's parameters.
    fn new(path: &Path, defines: &[(String, String)]) -> Self {
        Reader {
            params: defines.iter().cloned().collect(),
            defined: defines.iter().map(|(k, _)| k.clone()).collect(),
            search: vec![path.parent().map(Path::to_path_buf).unwrap_or_default()],
            ids: HashMap::new(),
            open: Vec::new(),
        }
    }

    fn read_file(&mut self, path: &Path, top: bool) -> Result<Object, XmlError> {
        let err = |message: String| XmlError {
            at: at_file(path),
            message,
        };
        let canonical = path.canonicalize().unwrap_or_else(|_| path.to_path_buf());
        if self.open.contains(&canonical) {
            return Err(err("the file includes itself".into()));
        }
        if self.open.len() >= MAX_INCLUDE_DEPTH {
            return Err(err(format!(
                "includes nest deeper than {MAX_INCLUDE_DEPTH} files"
            )));
        }
        let meta = std::fs::metadata(path).map_err(|e| err(e.to_string()))?;
        if meta.len() > MAX_XML_BYTES {
            return Err(err(format!(
                "{} bytes is larger than a scene file may be ({MAX_XML_BYTES})",
                meta.len()
            )));
        }
        let text = std::fs::read_to_string(path).map_err(|e| err(e.to_string()))?;
        self.open.push(canonical);
        let result = self.read_text(&text, path, top);
        self.open.pop();
        result
    }

    fn read_text(&mut self, text: &str, path: &Path, top: bool) -> Result<Object, XmlError> {
        let doc = roxmltree::Document::parse(text).map_err(|e| {
            let pos = e.pos();
            XmlError {
                at: Location {
                    file: path.to_path_buf(),
                    line: pos.row,
                    column: pos.col,
                },
                message: format!("not well-formed XML: {e}"),
            }
        })?;
        let root = doc.root_element();
        let file = Rc::new(FileCtx {
            path: path.to_path_buf(),
            doc: &doc,
        });
        let at = file.at(root);
        if root.tag_name().name() != "scene" {
            return Err(XmlError {
                at,
                message: format!(
                    "the root element is <{}>, not <scene>",
                    root.tag_name().name()
                ),
            });
        }
        let version = root.attribute("version").ok_or_else(|| XmlError {
            at: at.clone(),
            message: "<scene> has no version attribute".into(),
        })?;
        let major = version
            .split('.')
            .next()
            .and_then(|m| m.trim().parse::<u32>().ok());
        match major {
            Some(2) | Some(3) => {}
            _ if top || major.is_none() => {
                return Err(XmlError {
                    at,
                    message: format!(
                        "scene version \"{version}\" is not supported (versions 2 and 3 are read)"
                    ),
                })
            }
            _ => {
                return Err(XmlError {
                    at,
                    message: format!("included scene version \"{version}\" is not supported"),
                })
            }
        }
        let mut scene = Object {
            tag: "scene".into(),
            kind: String::new(),
            id: None,
            props: Vec::new(),
            children: Vec::new(),
            at,
        };
        self.read_children(&file, root, &mut scene, true)?;
        Ok(scene)
    }

    /// Reads an element's children into `object`; at the scene level
    /// (`scene_level`) the scene-only elements are allowed.
    fn read_children(
        &mut self,
        file: &FileCtx,
        node: roxmltree::Node,
        object: &mut Object,
        scene_level: bool,
    ) -> Result<(), XmlError> {
        for child in node.children().filter(|c| c.is_element()) {
            let tag = child.tag_name().name();
            let at = file.at(child);
            let fail = |message: String| XmlError {
                at: at.clone(),
                message,
            };
            match tag {
                "default" if scene_level => {
                    self.check_attributes(file, child, &["name", "value"])?;
                    let name = self.attr(file, child, "name")?;
                    let value = child
                        .attribute("value")
                        .ok_or_else(|| fail("<default> has no value".into()))?;
                    if !self.defined.contains(&name) {
                        let value = self.substitute(file, child, value)?;
                        self.params.insert(name, value);
                    }
                }
                "path" if scene_level => {
                    self.check_attributes(file, child, &["value"])?;
                    let value = self.attr(file, child, "value")?;
                    let base = file.path.parent().unwrap_or(Path::new(""));
                    self.search.push(base.join(value));
                }
                "include" if scene_level => {
                    self.check_attributes(file, child, &["filename"])?;
                    let name = self.attr(file, child, "filename")?;
                    let path = self.find(file, &name);
                    let included = self.read_file(&path, false).map_err(|e| {
                        if e.at.file == path && e.at.line == 1 && e.at.column == 1 {
                            fail(format!("include \"{name}\": {}", e.message))
                        } else {
                            e
                        }
                    })?;
                    object.props.extend(included.props);
                    object.children.extend(included.children);
                }
                "alias" if scene_level => {
                    self.check_attributes(file, child, &["id", "as"])?;
                    let id = self.attr(file, child, "id")?;
                    let alias = self.attr(file, child, "as")?;
                    let target = self
                        .ids
                        .get(&id)
                        .cloned()
                        .ok_or_else(|| fail(format!("alias of unknown id \"{id}\"")))?;
                    self.define_id(&alias, target, &at)?;
                }
                "default" | "path" | "include" | "alias" => {
                    return Err(fail(format!("<{tag}> may appear only in <scene>")));
                }
                "ref" => {
                    self.check_attributes(file, child, &["id", "name"])?;
                    let id = self.attr(file, child, "id")?;
                    let target = self
                        .ids
                        .get(&id)
                        .cloned()
                        .ok_or_else(|| fail(format!("reference to unknown id \"{id}\"")))?;
                    let name = match child.attribute("name") {
                        Some(n) => Some(self.substitute(file, child, n)?),
                        None => None,
                    };
                    object.children.push(Child {
                        name,
                        object: target,
                    });
                }
                "transform" => {
                    self.check_attributes(file, child, &["name"])?;
                    let name = self.attr(file, child, "name")?;
                    let m = self.read_transform(file, child)?;
                    object.props.push(Property {
                        name,
                        value: Value::Transform(m),
                        at,
                    });
                }
                "float" | "integer" | "boolean" | "string" | "rgb" | "spectrum" | "point"
                | "vector"
                    if child.attribute("name").is_some() && child.attribute("type").is_none() =>
                {
                    let name = self.attr(file, child, "name")?;
                    let value = self.read_value(file, child, tag)?;
                    object.props.push(Property { name, value, at });
                }
                "spectrum" if child.attribute("type").is_some() => {
                    // A spectrum plugin (`<spectrum type="..."/>`): an object.
                    let obj = self.read_object(file, child)?;
                    object.children.push(obj);
                }
                t if OBJECT_TAGS.contains(&t) => {
                    let obj = self.read_object(file, child)?;
                    object.children.push(obj);
                }
                "scene" => return Err(fail("<scene> inside another element".into())),
                other => return Err(fail(format!("unknown element <{other}>"))),
            }
        }
        Ok(())
    }

    fn read_object(&mut self, file: &FileCtx, node: roxmltree::Node) -> Result<Child, XmlError> {
        let at = file.at(node);
        self.check_attributes(file, node, &["type", "id", "name"])?;
        let kind = self.attr(file, node, "type")?;
        let id = match node.attribute("id") {
            Some(v) => Some(self.substitute(file, node, v)?),
            None => None,
        };
        let name = match node.attribute("name") {
            Some(v) => Some(self.substitute(file, node, v)?),
            None => None,
        };
        let mut object = Object {
            tag: node.tag_name().name().to_string(),
            kind,
            id: id.clone(),
            props: Vec::new(),
            children: Vec::new(),
            at: at.clone(),
        };
        self.read_children(file, node, &mut object, false)?;
        let object = Rc::new(object);
        if let Some(id) = id {
            self.define_id(&id, object.clone(), &at)?;
        }
        Ok(Child { name, object })
    }

    fn define_id(&mut self, id: &str, object: Rc<Object>, at: &Location) -> Result<(), XmlError> {
        if let Some(earlier) = self.ids.get(id) {
            return Err(XmlError {
                at: at.clone(),
                message: format!("id \"{id}\" was already defined at {}", earlier.at),
            });
        }
        self.ids.insert(id.to_string(), object);
        Ok(())
    }

    /// A file name an `include` gave, searched as [`Document::resolve`]
    /// does with the folders known so far.
    fn find(&self, file: &FileCtx, name: &str) -> PathBuf {
        let p = Path::new(name);
        if p.is_absolute() {
            return p.to_path_buf();
        }
        for dir in self.search.iter().rev() {
            if dir.join(p).exists() {
                return dir.join(p);
            }
        }
        file.path.parent().unwrap_or(Path::new("")).join(p)
    }

    /// Refuses attributes an element does not take (a misspelt attribute
    /// would otherwise be silently ignored).
    fn check_attributes(
        &self,
        file: &FileCtx,
        node: roxmltree::Node,
        allowed: &[&str],
    ) -> Result<(), XmlError> {
        for a in node.attributes() {
            if !allowed.contains(&a.name()) {
                return Err(XmlError {
                    at: file.at(node),
                    message: format!(
                        "<{}> has an unexpected attribute \"{}\"",
                        node.tag_name().name(),
                        a.name()
                    ),
                });
            }
        }
        Ok(())
    }

    /// An attribute that must be there, with `$name` substituted.
    fn attr(&self, file: &FileCtx, node: roxmltree::Node, name: &str) -> Result<String, XmlError> {
        let raw = node.attribute(name).ok_or_else(|| XmlError {
            at: file.at(node),
            message: format!("<{}> has no \"{name}\" attribute", node.tag_name().name()),
        })?;
        self.substitute(file, node, raw)
    }

    /// Replaces each `$name` with its parameter's value. A `$` followed
    /// by a name that is no parameter is an error, as Mitsuba's.
    fn substitute(
        &self,
        file: &FileCtx,
        node: roxmltree::Node,
        raw: &str,
    ) -> Result<String, XmlError> {
        if !raw.contains('$') {
            return Ok(raw.to_string());
        }
        let mut out = String::with_capacity(raw.len());
        let mut rest = raw;
        while let Some(i) = rest.find('$') {
            out.push_str(&rest[..i]);
            let after = &rest[i + 1..];
            let len = after
                .char_indices()
                .find(|(_, c)| !(c.is_ascii_alphanumeric() || *c == '_'))
                .map_or(after.len(), |(j, _)| j);
            let name = &after[..len];
            if name.is_empty() {
                out.push('$');
                rest = after;
                continue;
            }
            // The longest parameter name that prefixes what follows `$`
            // (Mitsuba replaces each known `$name` textually).
            let known = (1..=len)
                .rev()
                .map(|k| &name[..k])
                .find(|k| self.params.contains_key(*k));
            match known {
                Some(k) => {
                    out.push_str(&self.params[k]);
                    rest = &after[k.len()..];
                }
                None => {
                    return Err(XmlError {
                        at: file.at(node),
                        message: format!(
                        "\"${name}\" names no parameter (give it with <default> or -D {name}=...)"
                    ),
                    })
                }
            }
        }
        out.push_str(rest);
        Ok(out)
    }

    fn read_value(
        &self,
        file: &FileCtx,
        node: roxmltree::Node,
        tag: &str,
    ) -> Result<Value, XmlError> {
        let fail = |message: String| XmlError {
            at: file.at(node),
            message,
        };
        let value = |s: &Self| s.attr(file, node, "value");
        match tag {
            "float" => {
                self.check_attributes(file, node, &["name", "value"])?;
                let v = value(self)?;
                parse_float(&v)
                    .map(Value::Float)
                    .ok_or_else(|| fail(format!("\"{v}\" is not a number")))
            }
            "integer" => {
                self.check_attributes(file, node, &["name", "value"])?;
                let v = value(self)?;
                v.trim()
                    .parse::<i64>()
                    .map(Value::Integer)
                    .map_err(|_| fail(format!("\"{v}\" is not an integer")))
            }
            "boolean" => {
                self.check_attributes(file, node, &["name", "value"])?;
                let v = value(self)?;
                match v.trim().to_ascii_lowercase().as_str() {
                    "true" => Ok(Value::Boolean(true)),
                    "false" => Ok(Value::Boolean(false)),
                    _ => Err(fail(format!("\"{v}\" is not true or false"))),
                }
            }
            "string" => {
                self.check_attributes(file, node, &["name", "value"])?;
                Ok(Value::String(value(self)?))
            }
            "rgb" => {
                self.check_attributes(file, node, &["name", "value"])?;
                let v = value(self)?;
                let n = parse_list(&v).ok_or_else(|| fail(format!("\"{v}\" is not numbers")))?;
                match n.as_slice() {
                    [g] => Ok(Value::Rgb(DVec3::splat(*g))),
                    [r, g, b] => Ok(Value::Rgb(DVec3::new(*r, *g, *b))),
                    _ => Err(fail(format!("rgb \"{v}\" needs one or three values"))),
                }
            }
            "spectrum" => {
                self.check_attributes(file, node, &["name", "value", "filename"])?;
                if node.attribute("filename").is_some() {
                    return Err(fail(
                        "a spectrum read from a file is not supported (give its values)".into(),
                    ));
                }
                let v = value(self)?;
                parse_spectrum(&v)
                    .map(Value::Spectrum)
                    .map_err(|m| fail(format!("spectrum \"{v}\": {m}")))
            }
            "point" | "vector" => {
                self.check_attributes(file, node, &["name", "value", "x", "y", "z"])?;
                let p = self.read_xyz(file, node, 0.0)?;
                Ok(if tag == "point" {
                    Value::Point(p)
                } else {
                    Value::Vector(p)
                })
            }
            other => Err(fail(format!("unknown value element <{other}>"))),
        }
    }

    /// `value="x, y, z"` or `x=".." y=".." z=".."` (missing ones
    /// `missing`); for `scale`, a single value applies to all three.
    fn read_xyz(
        &self,
        file: &FileCtx,
        node: roxmltree::Node,
        missing: f64,
    ) -> Result<DVec3, XmlError> {
        let fail = |message: String| XmlError {
            at: file.at(node),
            message,
        };
        if node.attribute("value").is_some() {
            if ["x", "y", "z"].iter().any(|a| node.attribute(*a).is_some()) {
                return Err(fail("give either value or x, y, z, not both".into()));
            }
            let v = self.attr(file, node, "value")?;
            let n = parse_list(&v).ok_or_else(|| fail(format!("\"{v}\" is not numbers")))?;
            return match n.as_slice() {
                [s] if node.tag_name().name() == "scale" => Ok(DVec3::splat(*s)),
                [x, y, z] => Ok(DVec3::new(*x, *y, *z)),
                _ => Err(fail(format!("\"{v}\" needs three values"))),
            };
        }
        let mut p = DVec3::splat(missing);
        for (i, a) in ["x", "y", "z"].iter().enumerate() {
            if node.attribute(*a).is_some() {
                let v = self.attr(file, node, a)?;
                p[i] = parse_float(&v)
                    .ok_or_else(|| fail(format!("{a} = \"{v}\" is not a number")))?;
            }
        }
        Ok(p)
    }

    fn read_transform(&self, file: &FileCtx, node: roxmltree::Node) -> Result<DMat4, XmlError> {
        let mut m = DMat4::IDENTITY;
        for op in node.children().filter(|c| c.is_element()) {
            let fail = |message: String| XmlError {
                at: file.at(op),
                message,
            };
            let name = op.tag_name().name();
            let step = match name {
                "translate" => {
                    self.check_attributes(file, op, &["value", "x", "y", "z"])?;
                    DMat4::from_translation(self.read_xyz(file, op, 0.0)?)
                }
                "scale" => {
                    self.check_attributes(file, op, &["value", "x", "y", "z"])?;
                    DMat4::from_scale(self.read_xyz(file, op, 1.0)?)
                }
                "rotate" => {
                    self.check_attributes(file, op, &["value", "x", "y", "z", "angle"])?;
                    let axis = self.read_xyz(file, op, 0.0)?;
                    let angle = self.attr(file, op, "angle")?;
                    let angle = parse_float(&angle)
                        .ok_or_else(|| fail(format!("angle \"{angle}\" is not a number")))?;
                    if axis.length_squared() == 0.0 || !axis.is_finite() {
                        return Err(fail("rotate needs a non-zero axis".into()));
                    }
                    rotation(axis, angle.to_radians())
                }
                "matrix" => {
                    self.check_attributes(file, op, &["value"])?;
                    let v = self.attr(file, op, "value")?;
                    let n =
                        parse_list(&v).ok_or_else(|| fail(format!("\"{v}\" is not numbers")))?;
                    match n.len() {
                        // Row-major, as written.
                        16 => DMat4::from_cols_array(&n.try_into().unwrap()).transpose(),
                        9 => DMat4::from_mat3(
                            DMat3::from_cols_array(&n.try_into().unwrap()).transpose(),
                        ),
                        k => return Err(fail(format!("a matrix needs 9 or 16 values, not {k}"))),
                    }
                }
                "lookat" => {
                    self.check_attributes(file, op, &["origin", "target", "up"])?;
                    let get = |a: &str| -> Result<DVec3, XmlError> {
                        let v = self.attr(file, op, a)?;
                        let n = parse_list(&v)
                            .ok_or_else(|| fail(format!("{a} \"{v}\" is not numbers")))?;
                        match n.as_slice() {
                            [x, y, z] => Ok(DVec3::new(*x, *y, *z)),
                            _ => Err(fail(format!("{a} \"{v}\" needs three values"))),
                        }
                    };
                    let origin = get("origin")?;
                    let target = get("target")?;
                    let up = if op.attribute("up").is_some() {
                        get("up")?
                    } else {
                        DVec3::Y
                    };
                    look_at(origin, target, up).ok_or_else(|| {
                        fail("lookat needs a target apart from the origin and an up vector not along the view".into())
                    })?
                }
                other => return Err(fail(format!("unknown transform element <{other}>"))),
            };
            m = step * m;
        }
        if !m.is_finite() {
            return Err(XmlError {
                at: file.at(node),
                message: "the transform is not finite".into(),
            });
        }
        Ok(m)
    }
}

/// Mitsuba's look-at frame: +z toward the target, +y the up vector made
/// orthogonal, +x = y × z (to the image's left, as Mitsuba's sensors
/// see it), at `origin`.
pub fn look_at(origin: DVec3, target: DVec3, up: DVec3) -> Option<DMat4> {
    let dir = (target - origin).try_normalize()?;
    let left = up.cross(dir).try_normalize()?;
    let new_up = dir.cross(left);
    Some(DMat4::from_cols(
        left.extend(0.0),
        new_up.extend(0.0),
        dir.extend(0.0),
        origin.extend(1.0),
    ))
}

/// A number as Mitsuba's parser takes it (finite or not: the scene's
/// reader refuses non-finite values where they matter).
fn parse_float(s: &str) -> Option<f64> {
    s.trim().parse::<f64>().ok()
}

/// Numbers separated by commas and/or white space.
fn parse_list(s: &str) -> Option<Vec<f64>> {
    s.split(|c: char| c == ',' || c.is_whitespace())
        .filter(|t| !t.is_empty())
        .map(parse_float)
        .collect()
}

fn parse_spectrum(s: &str) -> Result<Spectrum, String> {
    if !s.contains(':') {
        let n = parse_list(s).ok_or("not a number")?;
        return match n.as_slice() {
            [v] => Ok(Spectrum::Uniform(*v)),
            _ => Err("give one value or wavelength:value pairs".into()),
        };
    }
    let mut pairs = Vec::new();
    for item in s.split(',').map(str::trim).filter(|t| !t.is_empty()) {
        let (w, v) = item
            .split_once(':')
            .ok_or_else(|| format!("\"{item}\" is not wavelength:value"))?;
        let (w, v) = (
            parse_float(w).ok_or_else(|| format!("\"{w}\" is not a wavelength"))?,
            parse_float(v).ok_or_else(|| format!("\"{v}\" is not a value"))?,
        );
        if let Some(&(last, _)) = pairs.last() {
            if w <= last {
                return Err("wavelengths must increase".into());
            }
        }
        pairs.push((w, v));
    }
    if pairs.len() < 2 {
        return Err("give at least two wavelength:value pairs".into());
    }
    Ok(Spectrum::Pairs(pairs))
}

/// One file's text and name, for locations.
struct FileCtx<'a, 'input> {
    path: PathBuf,
    doc: &'a roxmltree::Document<'input>,
}

impl FileCtx<'_, '_> {
    fn at(&self, node: roxmltree::Node) -> Location {
        let pos = self.doc.text_pos_at(node.range().start);
        Location {
            file: self.path.clone(),
            line: pos.row,
            column: pos.col,
        }
    }
}

/// Mitsuba 3's rotation by `angle` (radians) about `axis` as the file
/// gives it: Rodrigues' matrix `cos θ·I + (1 − cos θ)·a aᵀ + sin θ·[a]×`
/// of the axis unnormalized (Dr.Jit's `rotate`, which Mitsuba's reader and
/// `Transform4f::rotate` call; an axis a little off unit length then also
/// scales a little, as in Mitsuba).
fn rotation(axis: DVec3, angle: f64) -> DMat4 {
    let a = if crate::mutants::is(crate::mutants::Mutant::MitsubaRotateAxisNormalized) {
        axis.normalize()
    } else {
        axis
    };
    let (s, c) = angle.sin_cos();
    let k = 1.0 - c;
    DMat4::from_mat3(DMat3::from_cols(
        DVec3::new(
            c + a.x * a.x * k,
            a.x * a.y * k + a.z * s,
            a.x * a.z * k - a.y * s,
        ),
        DVec3::new(
            a.x * a.y * k - a.z * s,
            c + a.y * a.y * k,
            a.y * a.z * k + a.x * s,
        ),
        DVec3::new(
            a.x * a.z * k + a.y * s,
            a.y * a.z * k - a.x * s,
            c + a.z * a.z * k,
        ),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Document, XmlError> {
        parse_text(text, Path::new("/nowhere/scene.xml"), &[])
    }

    #[test]
    fn defaults_substitute_and_the_command_line_wins() {
        let text = r#"<scene version="3.0.0">
            <default name="spp" value="16"/>
            <default name="w" value="$spp"/>
            <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
            <film type="hdrfilm"><integer name="width" value="$w"/></film>
        </scene>"#;
        let doc = parse(text).unwrap();
        let spp = &doc.root.children[0].object.props[0];
        assert_eq!(spp.value, Value::Integer(16));
        assert_eq!(spp.at.line, 4);
        let d = parse_text(text, Path::new("s.xml"), &[("spp".into(), "3".into())]).unwrap();
        assert_eq!(d.root.children[0].object.props[0].value, Value::Integer(3));
        assert_eq!(d.root.children[1].object.props[0].value, Value::Integer(3));
        let e = parse(r#"<scene version="3.0.0"><film type="$nope"/></scene>"#).unwrap_err();
        assert!(e.message.contains("$nope"), "{e}");
    }

    #[test]
    fn references_share_the_object_and_ids_are_unique() {
        let doc = parse(
            r#"<scene version="2.0.0">
                <bsdf type="diffuse" id="a"/>
                <alias id="a" as="b"/>
                <shape type="sphere"><ref id="a"/></shape>
                <shape type="sphere"><ref name="bsdf" id="b"/></shape>
            </scene>"#,
        )
        .unwrap();
        let one = &doc.root.children[1].object.children[0];
        let two = &doc.root.children[2].object.children[0];
        assert!(Rc::ptr_eq(&one.object, &two.object));
        assert_eq!(two.name.as_deref(), Some("bsdf"));
        let e = parse(
            r#"<scene version="3.0.0"><bsdf type="diffuse" id="a"/><bsdf type="diffuse" id="a"/></scene>"#,
        )
        .unwrap_err();
        assert!(e.message.contains("already defined"), "{e}");
        let e =
            parse(r#"<scene version="3.0.0"><shape type="sphere"><ref id="x"/></shape></scene>"#)
                .unwrap_err();
        assert!(e.message.contains("unknown id"), "{e}");
    }

    #[test]
    fn transforms_compose_in_the_order_written() {
        let doc = parse(
            r#"<scene version="3.0.0"><shape type="sphere"><transform name="to_world">
                <scale value="2"/><rotate z="1" angle="90"/><translate x="1"/>
            </transform></shape></scene>"#,
        )
        .unwrap();
        let Value::Transform(m) = doc.root.children[0].object.props[0].value else {
            panic!("not a transform");
        };
        // (1,0,0) scaled to (2,0,0), rotated to (0,2,0), moved to (1,2,0).
        let p = m.transform_point3(DVec3::X);
        assert!((p - DVec3::new(1.0, 2.0, 0.0)).length() < 1e-12, "{p}");
        let doc = parse(
            r#"<scene version="3.0.0"><sensor type="perspective"><transform name="to_world">
                <matrix value="1 0 0 5  0 1 0 6  0 0 1 7  0 0 0 1"/>
            </transform></sensor></scene>"#,
        )
        .unwrap();
        let Value::Transform(m) = doc.root.children[0].object.props[0].value else {
            panic!("not a transform");
        };
        assert_eq!(m.transform_point3(DVec3::ZERO), DVec3::new(5.0, 6.0, 7.0));
    }

    #[test]
    fn look_at_is_mitsubas_frame() {
        let m = look_at(DVec3::ZERO, DVec3::new(0.0, 0.0, -1.0), DVec3::Y).unwrap();
        assert!((m.transform_vector3(DVec3::Z) - DVec3::NEG_Z).length() < 1e-12);
        assert!((m.transform_vector3(DVec3::Y) - DVec3::Y).length() < 1e-12);
        // Looking down -z with y up, the image's left is -x... seen from
        // the camera, +x of the frame is y × z = (0,1,0) × (0,0,-1) = -x.
        assert!((m.transform_vector3(DVec3::X) - DVec3::NEG_X).length() < 1e-12);
        assert!(look_at(DVec3::ZERO, DVec3::ZERO, DVec3::Y).is_none());
        assert!(look_at(DVec3::ZERO, DVec3::Y, DVec3::Y).is_none());
    }

    #[test]
    fn values_parse_and_bad_ones_are_placed() {
        let doc = parse(
            r#"<scene version="3.0.0"><emitter type="point">
                <rgb name="a" value="0.5"/><rgb name="b" value="1, 2 3"/>
                <spectrum name="c" value="2"/><spectrum name="d" value="400:1, 500:2"/>
                <point name="e" x="1" z="3"/><boolean name="f" value="True"/>
            </emitter></scene>"#,
        )
        .unwrap();
        let p = &doc.root.children[0].object.props;
        assert_eq!(p[0].value, Value::Rgb(DVec3::splat(0.5)));
        assert_eq!(p[1].value, Value::Rgb(DVec3::new(1.0, 2.0, 3.0)));
        assert_eq!(p[2].value, Value::Spectrum(Spectrum::Uniform(2.0)));
        assert_eq!(
            p[3].value,
            Value::Spectrum(Spectrum::Pairs(vec![(400.0, 1.0), (500.0, 2.0)]))
        );
        assert_eq!(p[4].value, Value::Point(DVec3::new(1.0, 0.0, 3.0)));
        assert_eq!(p[5].value, Value::Boolean(true));
        for (bad, what) in [
            (r#"<float name="x" value="abc"/>"#, "not a number"),
            (r#"<rgb name="x" value="1 2"/>"#, "one or three"),
            (r#"<spectrum name="x" value="500:1, 400:2"/>"#, "increase"),
            (r#"<integer name="x" value="1.5"/>"#, "not an integer"),
            (r#"<float name="x" valeu="1"/>"#, "unexpected attribute"),
            (r#"<wibble name="x"/>"#, "unknown element"),
        ] {
            let text = format!(
                "<scene version=\"3.0.0\">\n<shape type=\"sphere\">\n{bad}</shape></scene>"
            );
            let e = parse(&text).unwrap_err();
            assert!(e.message.contains(what), "{bad}: {e}");
            assert_eq!(e.at.line, 3, "{bad}: {e}");
        }
    }

    #[test]
    fn versions_and_structure_are_checked() {
        for (text, what) in [
            (r#"<scene version="0.6.0"/>"#, "version"),
            (r#"<scene/>"#, "no version"),
            (r#"<shape type="sphere"/>"#, "not <scene>"),
            (
                r#"<scene version="3.0.0"><shape type="sphere"><default name="a" value="1"/></shape></scene>"#,
                "only in <scene>",
            ),
            (r#"<scene version="3.0.0"><shape"#, "not well-formed"),
        ] {
            let e = parse(text).unwrap_err();
            assert!(e.message.contains(what), "{text}: {e}");
        }
    }

    #[test]
    fn includes_splice_and_cycles_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("part.xml"),
            r#"<scene version="2.0.0"><bsdf type="diffuse" id="p"/></scene>"#,
        )
        .unwrap();
        std::fs::write(
            dir.path().join("main.xml"),
            r#"<scene version="3.0.0"><include filename="part.xml"/><shape type="sphere"><ref id="p"/></shape></scene>"#,
        )
        .unwrap();
        let doc = parse_file(&dir.path().join("main.xml"), &[]).unwrap();
        assert_eq!(doc.root.children.len(), 2);
        std::fs::write(
            dir.path().join("loop.xml"),
            r#"<scene version="3.0.0"><include filename="loop.xml"/></scene>"#,
        )
        .unwrap();
        let e = parse_file(&dir.path().join("loop.xml"), &[]).unwrap_err();
        assert!(e.message.contains("includes itself"), "{e}");
        let e = parse_file(&dir.path().join("missing.xml"), &[]).unwrap_err();
        assert!(e.at.file.ends_with("missing.xml"), "{e}");
    }
}
