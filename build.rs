//! Generates the model's variable tables and its FMI 2.0 modelDescription.xml from the one
//! source of truth, `modelDescription/variables.toml`.
//!
//! Outputs (in OUT_DIR):
//! - `variables.rs`: the `Params` struct, the enumeration types, `VARIABLES` and the
//!   identity constants (`GUID`, `MODEL_IDENTIFIER`), included by `src/variables.rs`;
//! - `modelDescription.xml`: embedded in the library and packaged into the .fmu by
//!   `fmu-package/build.rs`.
//!
//! The GUID is a hash of every source file of the library, so an FMU whose binary and XML
//! disagree, or whose binary is older than the source, is detected at fmi2Instantiate.

use quick_xml::events::{BytesDecl, BytesEnd, BytesStart, Event};
use quick_xml::Writer;
use serde::Deserialize;
use std::collections::BTreeSet;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

#[derive(Deserialize)]
struct Table {
    model_name: String,
    model_identifier: String,
    description: String,
    stop_time: f64,
    step_size: f64,
    log_categories: Vec<Category>,
    units: Vec<Unit>,
    inputs: Vec<Var>,
    outputs: Vec<Var>,
    enumerations: Vec<Enumeration>,
    parameters: Vec<Var>,
}

#[derive(Deserialize)]
struct Category {
    name: String,
    description: String,
}

#[derive(Deserialize)]
struct Unit {
    name: String,
    #[serde(default)]
    kg: i32,
    #[serde(default)]
    m: i32,
    #[serde(default)]
    s: i32,
    #[serde(default, rename = "A")]
    a: i32,
    #[serde(default)]
    rad: i32,
}

#[derive(Deserialize)]
struct Enumeration {
    name: String,
    items: Vec<String>,
    descriptions: Vec<String>,
}

#[derive(Deserialize)]
#[serde(untagged)]
enum Start {
    Real(f64),
    Item(String),
}

#[derive(Deserialize)]
struct Var {
    vr: u32,
    name: String,
    #[serde(default)]
    unit: String,
    #[serde(rename = "type")]
    enum_type: Option<String>,
    start: Option<Start>,
    min: Option<f64>,
    max: Option<f64>,
    /// Range the bench tool's fits search (diagnose), within [min, max].
    search: Option<[f64; 2]>,
    /// The paper's identification range (Table 2), identify's default.
    paper_search: Option<[f64; 2]>,
    variability: Option<String>,
    #[serde(default)]
    group: String,
    description: String,
}

#[derive(Clone, Copy, PartialEq)]
enum Causality {
    Input,
    Output,
    Parameter,
}

impl Causality {
    fn xml(self) -> &'static str {
        match self {
            Causality::Input => "input",
            Causality::Output => "output",
            Causality::Parameter => "parameter",
        }
    }
    fn rust(self) -> &'static str {
        match self {
            Causality::Input => "Input",
            Causality::Output => "Output",
            Causality::Parameter => "Parameter",
        }
    }
}

fn main() {
    let root = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap());
    let out = PathBuf::from(std::env::var("OUT_DIR").unwrap());
    let table_path = root.join("modelDescription/variables.toml");
    for watched in ["modelDescription", "src", "build.rs", "Cargo.toml"] {
        println!("cargo:rerun-if-changed={watched}");
    }

    let text = std::fs::read_to_string(&table_path).expect("read modelDescription/variables.toml");
    let table: Table = toml::from_str(&text).unwrap_or_else(|e| panic!("variables.toml: {e}"));
    check(&table);
    let guid = source_guid(&root);

    std::fs::write(out.join("variables.rs"), rust_code(&table, &guid)).unwrap();
    std::fs::write(
        out.join("modelDescription.xml"),
        model_description(&table, &guid),
    )
    .unwrap();
}

/// Every value reference and name unique, every unit and enumeration defined.
fn check(t: &Table) {
    let mut vrs = BTreeSet::new();
    let mut names = BTreeSet::new();
    let units: BTreeSet<&str> = t.units.iter().map(|u| u.name.as_str()).collect();
    for v in all_vars(t).map(|(_, v)| v) {
        assert!(vrs.insert(v.vr), "duplicate value reference {}", v.vr);
        assert!(names.insert(v.name.as_str()), "duplicate name {}", v.name);
        assert!(
            v.unit.is_empty() || units.contains(v.unit.as_str()),
            "{}: unit {} not in units",
            v.name,
            v.unit
        );
        if let Some(ty) = &v.enum_type {
            assert!(
                t.enumerations.iter().any(|e| &e.name == ty),
                "{}: unknown enumeration {ty}",
                v.name
            );
        }
    }
}

fn all_vars(t: &Table) -> impl Iterator<Item = (Causality, &Var)> {
    let inputs = t.inputs.iter().map(|v| (Causality::Input, v));
    let outputs = t.outputs.iter().map(|v| (Causality::Output, v));
    let parameters = t.parameters.iter().map(|v| (Causality::Parameter, v));
    inputs.chain(outputs).chain(parameters)
}

/// FNV-1a over every library source file, formatted as a GUID.
fn source_guid(root: &Path) -> String {
    let mut files = Vec::new();
    collect_files(&root.join("src"), &mut files);
    collect_files(&root.join("modelDescription"), &mut files);
    files.push(root.join("build.rs"));
    files.push(root.join("Cargo.toml"));
    files.sort();
    let (mut h1, mut h2) = (0xcbf2_9ce4_8422_2325u64, 0x6c62_272e_07bb_0142u64);
    for f in &files {
        let rel = f
            .strip_prefix(root)
            .unwrap()
            .to_string_lossy()
            .replace('\\', "/");
        let bytes = std::fs::read(f).unwrap_or_default();
        for b in rel.bytes().chain([0u8]).chain(bytes) {
            h1 = (h1 ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3);
            h2 = (h2 ^ b as u64)
                .wrapping_mul(0x0000_0100_0000_01b3)
                .rotate_left(5);
        }
    }
    let hex = format!("{h1:016x}{h2:016x}");
    format!(
        "{{{}-{}-{}-{}-{}}}",
        &hex[0..8],
        &hex[8..12],
        &hex[12..16],
        &hex[16..20],
        &hex[20..32]
    )
}

fn collect_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            collect_files(&p, out);
        } else {
            out.push(p);
        }
    }
}

fn camel(s: &str) -> String {
    s.split('_')
        .map(|w| {
            let mut c = w.chars();
            c.next()
                .map(|f| f.to_ascii_uppercase().to_string() + c.as_str())
                .unwrap_or_default()
        })
        .collect()
}

/// A search range as Rust source, checked to lie within the variable's bounds.
fn range_lit(v: &Var, range: Option<[f64; 2]>) -> String {
    let Some([lo, hi]) = range else {
        return "None".into();
    };
    let (min, max) = (
        v.min.unwrap_or(f64::NEG_INFINITY),
        v.max.unwrap_or(f64::INFINITY),
    );
    assert!(
        min <= lo && lo < hi && hi <= max,
        "{}: search range [{lo}, {hi}] must be non-empty and within [{min}, {max}]",
        v.name
    );
    format!("Some(({}, {}))", lit(lo), lit(hi))
}

fn lit(x: f64) -> String {
    if x.is_infinite() {
        if x > 0.0 {
            "f64::INFINITY"
        } else {
            "f64::NEG_INFINITY"
        }
        .into()
    } else {
        format!("{x:?}_f64")
    }
}

fn enum_start<'a>(t: &'a Table, v: &Var) -> (&'a Enumeration, usize) {
    let e = t
        .enumerations
        .iter()
        .find(|e| Some(&e.name) == v.enum_type.as_ref())
        .unwrap();
    let Some(Start::Item(item)) = &v.start else {
        panic!("{}: enumeration start must be an item name", v.name)
    };
    let idx = e
        .items
        .iter()
        .position(|i| i == item)
        .unwrap_or_else(|| panic!("{}: {item} not an item of {}", v.name, e.name));
    (e, idx)
}

fn real_start(v: &Var) -> f64 {
    match &v.start {
        Some(Start::Real(x)) => *x,
        None => 0.0,
        Some(Start::Item(_)) => panic!("{}: real start must be a number", v.name),
    }
}

fn rust_code(t: &Table, guid: &str) -> String {
    let mut s = String::new();
    identity_code(&mut s, t, guid);
    for e in &t.enumerations {
        enumeration_code(&mut s, e);
    }
    params_struct(&mut s, t);
    params_access(&mut s, t);
    variables_table(&mut s, t);
    signal_struct(
        &mut s,
        "Inputs",
        "The model's inputs (held over a communication step).",
        &t.inputs,
    );
    signal_struct(
        &mut s,
        "Outputs",
        "The model's outputs at a communication point.",
        &t.outputs,
    );
    vr_module(&mut s, t);
    s
}

/// The FMU's identity: GUID, names, the embedded XML and the log categories.
fn identity_code(s: &mut String, t: &Table, guid: &str) {
    writeln!(
        s,
        "// Generated by build.rs from modelDescription/variables.toml. Do not edit."
    )
    .unwrap();
    writeln!(s, "pub const GUID: &str = {guid:?};").unwrap();
    writeln!(s, "pub const MODEL_NAME: &str = {:?};", t.model_name).unwrap();
    writeln!(
        s,
        "pub const MODEL_IDENTIFIER: &str = {:?};",
        t.model_identifier
    )
    .unwrap();
    writeln!(
        s,
        "pub const MODEL_DESCRIPTION_XML: &str = include_str!(concat!(env!(\"OUT_DIR\"), \"/modelDescription.xml\"));"
    )
    .unwrap();
    writeln!(
        s,
        "pub const LOG_CATEGORIES: &[&str] = &[{}];",
        quoted_list(t.log_categories.iter().map(|c| &c.name))
    )
    .unwrap();
}

/// `"a", "b", ...`: names as Rust string literals.
fn quoted_list<'a>(names: impl Iterator<Item = &'a String>) -> String {
    names
        .map(|n| format!("{n:?}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// An FMI enumeration as a Rust enum with its names and FMI values (1, 2, ...).
fn enumeration_code(s: &mut String, e: &Enumeration) {
    writeln!(s, "\n/// {} (FMI enumeration; values 1, 2, ...).", e.name).unwrap();
    writeln!(
        s,
        "#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]\npub enum {} {{",
        e.name
    )
    .unwrap();
    for (item, d) in e.items.iter().zip(&e.descriptions) {
        writeln!(s, "    /// {d}\n    {},", camel(item)).unwrap();
    }
    writeln!(s, "}}\nimpl {} {{", e.name).unwrap();
    writeln!(
        s,
        "    pub const NAMES: &'static [&'static str] = &[{}];",
        quoted_list(e.items.iter())
    )
    .unwrap();
    let all: Vec<String> = e
        .items
        .iter()
        .map(|i| format!("Self::{}", camel(i)))
        .collect();
    writeln!(
        s,
        "    pub const ALL: &'static [Self] = &[{}];",
        all.join(", ")
    )
    .unwrap();
    writeln!(
        s,
        "    pub fn name(self) -> &'static str {{ Self::NAMES[self as usize] }}"
    )
    .unwrap();
    writeln!(s, "    pub fn fmi_value(self) -> i32 {{ self as i32 + 1 }}").unwrap();
    writeln!(
        s,
        "    pub fn from_fmi_value(v: i32) -> Option<Self> {{ usize::try_from(v - 1).ok().and_then(|i| Self::ALL.get(i).copied()) }}"
    )
    .unwrap();
    writeln!(
        s,
        "    pub fn from_name(n: &str) -> Option<Self> {{ Self::NAMES.iter().position(|x| *x == n).map(|i| Self::ALL[i]) }}"
    )
    .unwrap();
    writeln!(s, "}}").unwrap();
}

/// The `Params` struct (one field per parameter, its unit in the doc) and its `Default`,
/// the parameters' start values.
fn params_struct(s: &mut String, t: &Table) {
    writeln!(
        s,
        "\n/// Every parameter of the model, by the name used in TOML files, the CLI and the FMU."
    )
    .unwrap();
    writeln!(
        s,
        "#[allow(non_snake_case)]\n#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]\npub struct Params {{"
    )
    .unwrap();
    for v in &t.parameters {
        let ty = v.enum_type.clone().unwrap_or_else(|| "f64".into());
        let unit = if v.unit.is_empty() {
            String::new()
        } else {
            format!(" [{}]", v.unit)
        };
        writeln!(
            s,
            "    /// {}{unit}\n    pub {}: {ty},",
            v.description, v.name
        )
        .unwrap();
    }
    writeln!(
        s,
        "}}\n\nimpl Default for Params {{\n    fn default() -> Self {{\n        Self {{"
    )
    .unwrap();
    for v in &t.parameters {
        let start = if v.enum_type.is_some() {
            let (e, idx) = enum_start(t, v);
            format!("{}::{}", e.name, camel(&e.items[idx]))
        } else {
            lit(real_start(v))
        };
        writeln!(s, "            {}: {start},", v.name).unwrap();
    }
    writeln!(s, "        }}\n    }}\n}}").unwrap();
}

/// `Params`' access by value reference: real and enumeration parameters.
fn params_access(s: &mut String, t: &Table) {
    let reals = || t.parameters.iter().filter(|v| v.enum_type.is_none());
    let enums = || t.parameters.iter().filter(|v| v.enum_type.is_some());
    writeln!(s, "\nimpl Params {{").unwrap();
    writeln!(
        s,
        "    /// The real-valued parameter with value reference `vr`."
    )
    .unwrap();
    vr_match(
        s,
        "pub fn real(&self, vr: u32) -> Option<f64>",
        reals().map(|v| (v.vr, format!("Some(self.{})", v.name))),
        "None",
    );
    vr_match(
        s,
        "pub fn real_mut(&mut self, vr: u32) -> Option<&mut f64>",
        reals().map(|v| (v.vr, format!("Some(&mut self.{})", v.name))),
        "None",
    );
    writeln!(
        s,
        "    /// The enumeration parameter with value reference `vr`, as its FMI value."
    )
    .unwrap();
    vr_match(
        s,
        "pub fn enumeration(&self, vr: u32) -> Option<i32>",
        enums().map(|v| (v.vr, format!("Some(self.{}.fmi_value())", v.name))),
        "None",
    );
    writeln!(
        s,
        "    /// Sets an enumeration parameter from its FMI value; false if `vr` or `value` is not valid."
    )
    .unwrap();
    vr_match(
        s,
        "pub fn set_enumeration(&mut self, vr: u32, value: i32) -> bool",
        enums().map(|v| {
            let ty = v.enum_type.as_ref().unwrap();
            let set = format!("{ty}::from_fmi_value(value).map(|e| self.{} = e)", v.name);
            (v.vr, format!("{set}.is_some()"))
        }),
        "false",
    );
    writeln!(s, "}}").unwrap();
}

/// A method whose body matches `vr`: one arm per value reference, `otherwise` for the rest.
fn vr_match(
    s: &mut String,
    signature: &str,
    arms: impl Iterator<Item = (u32, String)>,
    otherwise: &str,
) {
    writeln!(s, "    {signature} {{\n        match vr {{").unwrap();
    for (vr, value) in arms {
        writeln!(s, "            {vr} => {value},").unwrap();
    }
    writeln!(s, "            _ => {otherwise},\n        }}\n    }}").unwrap();
}

/// `VARIABLES`: every variable of the model, in modelDescription order.
fn variables_table(s: &mut String, t: &Table) {
    writeln!(
        s,
        "\n/// Every variable of the model, in modelDescription order."
    )
    .unwrap();
    writeln!(s, "pub static VARIABLES: &[Variable] = &[").unwrap();
    for (c, v) in all_vars(t) {
        writeln!(s, "    {},", variable_entry(t, c, v)).unwrap();
    }
    writeln!(s, "];").unwrap();
}

/// One `Variable { .. }` of `VARIABLES`.
fn variable_entry(t: &Table, c: Causality, v: &Var) -> String {
    let variability = match c {
        Causality::Parameter => match v.variability.as_deref() {
            Some("tunable") => "Tunable",
            Some("fixed") => "Fixed",
            other => panic!("{}: parameter variability {other:?}", v.name),
        },
        _ => "Continuous",
    };
    let kind = match &v.enum_type {
        Some(ty) => {
            let (_, idx) = enum_start(t, v);
            format!(
                "Kind::Enumeration {{ names: {ty}::NAMES, start: {} }}",
                idx as i32 + 1
            )
        }
        None => format!(
            "Kind::Real {{ start: {}, min: {}, max: {} }}",
            lit(real_start(v)),
            lit(v.min.unwrap_or(f64::NEG_INFINITY)),
            lit(v.max.unwrap_or(f64::INFINITY))
        ),
    };
    let (search, paper_search) = (range_lit(v, v.search), range_lit(v, v.paper_search));
    format!(
        "Variable {{ name: {:?}, vr: {}, causality: Causality::{}, variability: Variability::{variability}, kind: {kind}, search: {search}, paper_search: {paper_search}, unit: {:?}, group: {:?}, description: {:?} }}",
        v.name, v.vr, c.rust(), v.unit, v.group, v.description
    )
}

/// `vr::NAME`: the value references of the inputs and outputs, as constants.
fn vr_module(s: &mut String, t: &Table) {
    writeln!(
        s,
        "\n/// Value references of the inputs and outputs, as constants.\npub mod vr {{"
    )
    .unwrap();
    for v in t.inputs.iter().chain(&t.outputs) {
        writeln!(
            s,
            "    pub const {}: u32 = {};",
            v.name.to_ascii_uppercase(),
            v.vr
        )
        .unwrap();
    }
    writeln!(s, "}}").unwrap();
}

/// A plain struct of named signals with by-value-reference access and a name list.
fn signal_struct(s: &mut String, name: &str, doc: &str, vars: &[Var]) {
    writeln!(s, "\n/// {doc}\n#[allow(non_snake_case)]").unwrap();
    writeln!(
        s,
        "#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]\npub struct {name} {{"
    )
    .unwrap();
    for v in vars {
        writeln!(
            s,
            "    /// {} [{}]\n    pub {}: f64,",
            v.description, v.unit, v.name
        )
        .unwrap();
    }
    writeln!(s, "}}\nimpl {name} {{").unwrap();
    writeln!(
        s,
        "    pub const NAMES: &'static [&'static str] = &[{}];",
        quoted_list(vars.iter().map(|v| &v.name))
    )
    .unwrap();
    writeln!(
        s,
        "    pub fn values(&self) -> [f64; {}] {{ [{}] }}",
        vars.len(),
        vars.iter()
            .map(|v| format!("self.{}", v.name))
            .collect::<Vec<_>>()
            .join(", ")
    )
    .unwrap();
    vr_match(
        s,
        "pub fn get(&self, vr: u32) -> Option<f64>",
        vars.iter()
            .map(|v| (v.vr, format!("Some(self.{})", v.name))),
        "None",
    );
    vr_match(
        s,
        "pub fn get_mut(&mut self, vr: u32) -> Option<&mut f64>",
        vars.iter()
            .map(|v| (v.vr, format!("Some(&mut self.{})", v.name))),
        "None",
    );
    writeln!(s, "}}").unwrap();
}

fn fmt_num(x: f64) -> String {
    format!("{x:?}").trim_end_matches(".0").to_string()
}

/// An XML writer of the few events modelDescription.xml needs.
struct Xml(Writer<Vec<u8>>);

type Attrs<'a> = [(&'a str, String)];

impl Xml {
    fn element(tag: &str, attrs: &Attrs) -> BytesStart<'static> {
        let mut e = BytesStart::new(tag.to_string());
        for (k, v) in attrs {
            e.push_attribute((*k, v.as_str()));
        }
        e
    }
    fn start(&mut self, tag: &str, attrs: &Attrs) {
        let e = Self::element(tag, attrs);
        self.0.write_event(Event::Start(e)).unwrap();
    }
    fn empty(&mut self, tag: &str, attrs: &Attrs) {
        let e = Self::element(tag, attrs);
        self.0.write_event(Event::Empty(e)).unwrap();
    }
    fn end(&mut self, tag: &str) {
        self.0.write_event(Event::End(BytesEnd::new(tag))).unwrap();
    }
}

/// An attribute of an XML element.
fn attr(k: &'static str, v: &str) -> (&'static str, String) {
    (k, v.to_string())
}

fn model_description(t: &Table, guid: &str) -> String {
    let mut w = Xml(Writer::new_with_indent(Vec::new(), b' ', 2));
    w.0.write_event(Event::Decl(BytesDecl::new("1.0", Some("UTF-8"), None)))
        .unwrap();
    w.start(
        "fmiModelDescription",
        &[
            attr("fmiVersion", "2.0"),
            attr("modelName", &t.model_name),
            attr("guid", guid),
            attr("description", &t.description),
            attr(
                "generationTool",
                concat!("tbm-thrust ", env!("CARGO_PKG_VERSION"), " build.rs"),
            ),
            attr("variableNamingConvention", "flat"),
            attr("numberOfEventIndicators", "0"),
        ],
    );
    co_simulation(&mut w, t);
    unit_definitions(&mut w, t);
    type_definitions(&mut w, t);
    log_categories(&mut w, t);
    w.empty(
        "DefaultExperiment",
        &[
            attr("startTime", "0"),
            ("stopTime", fmt_num(t.stop_time)),
            ("stepSize", fmt_num(t.step_size)),
        ],
    );
    let output_index = model_variables(&mut w, t);
    model_structure(&mut w, &output_index);
    w.end("fmiModelDescription");
    let mut xml = String::from_utf8(w.0.into_inner()).unwrap();
    xml.push('\n');
    xml
}

/// The co-simulation capabilities: what an importer may ask of this FMU.
fn co_simulation(w: &mut Xml, t: &Table) {
    w.empty(
        "CoSimulation",
        &[
            attr("modelIdentifier", &t.model_identifier),
            attr("needsExecutionTool", "false"),
            attr("canHandleVariableCommunicationStepSize", "true"),
            attr("canInterpolateInputs", "false"),
            attr("maxOutputDerivativeOrder", "0"),
            attr("canRunAsynchronuously", "false"),
            attr("canBeInstantiatedOnlyOncePerProcess", "false"),
            attr("canNotUseMemoryManagementFunctions", "true"),
            attr("canGetAndSetFMUstate", "true"),
            attr("canSerializeFMUstate", "true"),
            attr("providesDirectionalDerivative", "false"),
        ],
    );
}

/// Every unit by its SI base-unit exponents.
fn unit_definitions(w: &mut Xml, t: &Table) {
    w.start("UnitDefinitions", &[]);
    for u in &t.units {
        w.start("Unit", &[attr("name", &u.name)]);
        let exponents = [
            ("kg", u.kg),
            ("m", u.m),
            ("s", u.s),
            ("A", u.a),
            ("rad", u.rad),
        ];
        let base: Vec<_> = exponents
            .into_iter()
            .filter(|&(_, e)| e != 0)
            .map(|(k, e)| (k, e.to_string()))
            .collect();
        w.empty("BaseUnit", &base);
        w.end("Unit");
    }
    w.end("UnitDefinitions");
}

fn type_definitions(w: &mut Xml, t: &Table) {
    w.start("TypeDefinitions", &[]);
    for e in &t.enumerations {
        w.start("SimpleType", &[attr("name", &e.name)]);
        w.start("Enumeration", &[]);
        for (i, (item, d)) in e.items.iter().zip(&e.descriptions).enumerate() {
            let value = ("value", (i + 1).to_string());
            w.empty("Item", &[attr("name", item), value, attr("description", d)]);
        }
        w.end("Enumeration");
        w.end("SimpleType");
    }
    w.end("TypeDefinitions");
}

fn log_categories(w: &mut Xml, t: &Table) {
    w.start("LogCategories", &[]);
    for c in &t.log_categories {
        w.empty(
            "Category",
            &[attr("name", &c.name), attr("description", &c.description)],
        );
    }
    w.end("LogCategories");
}

/// Every ScalarVariable; returns the outputs' 1-based indices for the model structure.
fn model_variables(w: &mut Xml, t: &Table) -> Vec<usize> {
    w.start("ModelVariables", &[]);
    let mut output_index = Vec::new();
    for (i, (c, v)) in all_vars(t).enumerate() {
        let mut attrs = vec![
            attr("name", &v.name),
            ("valueReference", v.vr.to_string()),
            attr("description", &v.description),
            attr("causality", c.xml()),
        ];
        match c {
            Causality::Parameter => {
                attrs.push(("variability", v.variability.clone().unwrap()));
                attrs.push(attr("initial", "exact"));
            }
            Causality::Input => attrs.push(attr("variability", "continuous")),
            Causality::Output => {
                attrs.push(attr("variability", "continuous"));
                attrs.push(attr("initial", "calculated"));
                output_index.push(i + 1);
            }
        }
        w.start("ScalarVariable", &attrs);
        variable_type(w, t, c, v);
        w.end("ScalarVariable");
    }
    assert_eq!(
        all_vars(t).count(),
        output_index.len() + t.inputs.len() + t.parameters.len()
    );
    w.end("ModelVariables");
    output_index
}

/// A variable's type element: its enumeration and start item, or Real with start, unit
/// and bounds.
fn variable_type(w: &mut Xml, t: &Table, c: Causality, v: &Var) {
    if let Some(ty) = &v.enum_type {
        let (_, idx) = enum_start(t, v);
        w.empty(
            "Enumeration",
            &[attr("declaredType", ty), ("start", (idx + 1).to_string())],
        );
        return;
    }
    let mut r = Vec::new();
    if c != Causality::Output {
        r.push(("start", fmt_num(real_start(v))));
    }
    if !v.unit.is_empty() {
        r.push(attr("unit", &v.unit));
    }
    if let Some(x) = v.min {
        r.push(("min", fmt_num(x)));
    }
    if let Some(x) = v.max {
        r.push(("max", fmt_num(x)));
    }
    w.empty("Real", &r);
}

/// The outputs, which are also the initial unknowns (no `dependencies` listed: each may
/// depend on every input and parameter).
fn model_structure(w: &mut Xml, output_index: &[usize]) {
    w.start("ModelStructure", &[]);
    for section in ["Outputs", "InitialUnknowns"] {
        w.start(section, &[]);
        for i in output_index {
            w.empty("Unknown", &[("index", i.to_string())]);
        }
        w.end(section);
    }
    w.end("ModelStructure");
}
