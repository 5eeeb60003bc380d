//! A general PLY reader and writer.
//!
//! Reads `ascii`, `binary_little_endian` and `binary_big_endian` files with any
//! element and property layout: scalar properties of every PLY type (both the
//! classic `char … double` and the `int8 … float64` spellings) and list
//! properties with any integer count type and any item type. `comment` and
//! `obj_info` lines are kept. In memory an element is a set of named, typed
//! columns; a list property is an offsets array plus one flat column of items.
//!
//! Untrusted input: a header that lies (counts beyond the end of the file, an
//! unknown type, a negative or oversized list count, truncated data) is an error
//! naming the file, element, row, property and byte offset. Nothing is allocated
//! from a declared count before the bytes backing it are known to exist.

use std::fmt;
use std::io::Write;
use std::path::Path;

/// A PLY failure, with where it happened.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{source_name}: {message}")]
pub struct PlyError {
    /// The file (or other source) being read or written.
    pub source_name: String,
    /// What went wrong, naming the element/property/byte offset when known.
    pub message: String,
}

impl PlyError {
    fn new(source_name: &str, message: impl Into<String>) -> PlyError {
        PlyError {
            source_name: source_name.to_string(),
            message: message.into(),
        }
    }
}

/// The storage format of a PLY body.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    Ascii,
    BinaryLittleEndian,
    BinaryBigEndian,
}

impl Format {
    fn keyword(self) -> &'static str {
        match self {
            Format::Ascii => "ascii",
            Format::BinaryLittleEndian => "binary_little_endian",
            Format::BinaryBigEndian => "binary_big_endian",
        }
    }
}

/// A PLY scalar type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ScalarType {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl ScalarType {
    /// Parses either spelling (`uchar` or `uint8`, …).
    pub fn parse(word: &str) -> Option<ScalarType> {
        Some(match word {
            "char" | "int8" => ScalarType::I8,
            "uchar" | "uint8" => ScalarType::U8,
            "short" | "int16" => ScalarType::I16,
            "ushort" | "uint16" => ScalarType::U16,
            "int" | "int32" => ScalarType::I32,
            "uint" | "uint32" => ScalarType::U32,
            "float" | "float32" => ScalarType::F32,
            "double" | "float64" => ScalarType::F64,
            _ => return None,
        })
    }

    /// The classic spelling, which every PLY reader understands.
    pub fn keyword(self) -> &'static str {
        match self {
            ScalarType::I8 => "char",
            ScalarType::U8 => "uchar",
            ScalarType::I16 => "short",
            ScalarType::U16 => "ushort",
            ScalarType::I32 => "int",
            ScalarType::U32 => "uint",
            ScalarType::F32 => "float",
            ScalarType::F64 => "double",
        }
    }

    pub fn size(self) -> usize {
        match self {
            ScalarType::I8 | ScalarType::U8 => 1,
            ScalarType::I16 | ScalarType::U16 => 2,
            ScalarType::I32 | ScalarType::U32 | ScalarType::F32 => 4,
            ScalarType::F64 => 8,
        }
    }

    pub fn is_integer(self) -> bool {
        !matches!(self, ScalarType::F32 | ScalarType::F64)
    }

    /// Inclusive range of an integer type (`None` for floats).
    fn integer_range(self) -> Option<(i64, i64)> {
        Some(match self {
            ScalarType::I8 => (i8::MIN.into(), i8::MAX.into()),
            ScalarType::U8 => (0, u8::MAX.into()),
            ScalarType::I16 => (i16::MIN.into(), i16::MAX.into()),
            ScalarType::U16 => (0, u16::MAX.into()),
            ScalarType::I32 => (i32::MIN.into(), i32::MAX.into()),
            ScalarType::U32 => (0, u32::MAX.into()),
            ScalarType::F32 | ScalarType::F64 => return None,
        })
    }
}

impl fmt::Display for ScalarType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.keyword())
    }
}

/// A typed column of values.
#[derive(Debug, Clone, PartialEq)]
pub enum Column {
    I8(Vec<i8>),
    U8(Vec<u8>),
    I16(Vec<i16>),
    U16(Vec<u16>),
    I32(Vec<i32>),
    U32(Vec<u32>),
    F32(Vec<f32>),
    F64(Vec<f64>),
}

impl Column {
    pub fn empty(ty: ScalarType, capacity: usize) -> Column {
        match ty {
            ScalarType::I8 => Column::I8(Vec::with_capacity(capacity)),
            ScalarType::U8 => Column::U8(Vec::with_capacity(capacity)),
            ScalarType::I16 => Column::I16(Vec::with_capacity(capacity)),
            ScalarType::U16 => Column::U16(Vec::with_capacity(capacity)),
            ScalarType::I32 => Column::I32(Vec::with_capacity(capacity)),
            ScalarType::U32 => Column::U32(Vec::with_capacity(capacity)),
            ScalarType::F32 => Column::F32(Vec::with_capacity(capacity)),
            ScalarType::F64 => Column::F64(Vec::with_capacity(capacity)),
        }
    }

    pub fn scalar_type(&self) -> ScalarType {
        match self {
            Column::I8(_) => ScalarType::I8,
            Column::U8(_) => ScalarType::U8,
            Column::I16(_) => ScalarType::I16,
            Column::U16(_) => ScalarType::U16,
            Column::I32(_) => ScalarType::I32,
            Column::U32(_) => ScalarType::U32,
            Column::F32(_) => ScalarType::F32,
            Column::F64(_) => ScalarType::F64,
        }
    }

    pub fn len(&self) -> usize {
        match self {
            Column::I8(v) => v.len(),
            Column::U8(v) => v.len(),
            Column::I16(v) => v.len(),
            Column::U16(v) => v.len(),
            Column::I32(v) => v.len(),
            Column::U32(v) => v.len(),
            Column::F32(v) => v.len(),
            Column::F64(v) => v.len(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Value `i` as f64 (exact for every PLY type).
    pub fn get_f64(&self, i: usize) -> f64 {
        match self {
            Column::F32(v) => v[i].into(),
            Column::F64(v) => v[i],
            // Integer columns hold at most 32 bits: exact as i64 and as f64.
            _ => self
                .get_i64(i)
                .expect("get_i64 is Some for integer columns") as f64,
        }
    }

    /// Value `i` as i64, for integer columns only.
    pub fn get_i64(&self, i: usize) -> Option<i64> {
        Some(match self {
            Column::I8(v) => v[i].into(),
            Column::U8(v) => v[i].into(),
            Column::I16(v) => v[i].into(),
            Column::U16(v) => v[i].into(),
            Column::I32(v) => v[i].into(),
            Column::U32(v) => v[i].into(),
            Column::F32(_) | Column::F64(_) => return None,
        })
    }

    /// Appends one value decoded from exactly `size()` bytes.
    fn push_bytes(&mut self, b: &[u8], big_endian: bool) {
        macro_rules! push {
            ($v:expr, $t:ty, $n:literal) => {{
                // The caller slices exactly `$n` bytes, so the conversion cannot fail.
                let a: [u8; $n] = b.try_into().expect("caller passes exactly the type's size");
                $v.push(if big_endian {
                    <$t>::from_be_bytes(a)
                } else {
                    <$t>::from_le_bytes(a)
                })
            }};
        }
        match self {
            Column::I8(v) => push!(v, i8, 1),
            Column::U8(v) => push!(v, u8, 1),
            Column::I16(v) => push!(v, i16, 2),
            Column::U16(v) => push!(v, u16, 2),
            Column::I32(v) => push!(v, i32, 4),
            Column::U32(v) => push!(v, u32, 4),
            Column::F32(v) => push!(v, f32, 4),
            Column::F64(v) => push!(v, f64, 8),
        }
    }

    /// Appends one value parsed from an ASCII token; `Err` says why the token does not fit.
    fn push_token(&mut self, token: &str) -> Result<(), String> {
        fn int<T: TryFrom<i64>>(token: &str, ty: &str) -> Result<T, String> {
            let wide: i64 = token
                .parse()
                .map_err(|_| format!("{token:?} is not an integer"))?;
            T::try_from(wide).map_err(|_| format!("{token} does not fit in {ty}"))
        }
        fn float(token: &str) -> Result<f64, String> {
            token
                .parse::<f64>()
                .map_err(|_| format!("{token:?} is not a number"))
        }
        match self {
            Column::I8(v) => v.push(int(token, "char")?),
            Column::U8(v) => v.push(int(token, "uchar")?),
            Column::I16(v) => v.push(int(token, "short")?),
            Column::U16(v) => v.push(int(token, "ushort")?),
            Column::I32(v) => v.push(int(token, "int")?),
            Column::U32(v) => v.push(int(token, "uint")?),
            Column::F32(v) => v.push(
                token
                    .parse::<f32>()
                    .map_err(|_| format!("{token:?} is not a number"))?,
            ),
            Column::F64(v) => v.push(float(token)?),
        }
        Ok(())
    }

    fn write_binary(&self, i: usize, big_endian: bool, out: &mut Vec<u8>) {
        macro_rules! put {
            ($v:expr) => {
                if big_endian {
                    out.extend_from_slice(&$v[i].to_be_bytes())
                } else {
                    out.extend_from_slice(&$v[i].to_le_bytes())
                }
            };
        }
        match self {
            Column::I8(v) => put!(v),
            Column::U8(v) => put!(v),
            Column::I16(v) => put!(v),
            Column::U16(v) => put!(v),
            Column::I32(v) => put!(v),
            Column::U32(v) => put!(v),
            Column::F32(v) => put!(v),
            Column::F64(v) => put!(v),
        }
    }

    fn write_ascii(&self, i: usize, out: &mut String) {
        use fmt::Write as _;
        // `Display` for floats prints the shortest text that parses back to the same
        // value, so ASCII files round-trip exactly. Writing to a String cannot fail.
        let _ = match self {
            Column::I8(v) => write!(out, "{}", v[i]),
            Column::U8(v) => write!(out, "{}", v[i]),
            Column::I16(v) => write!(out, "{}", v[i]),
            Column::U16(v) => write!(out, "{}", v[i]),
            Column::I32(v) => write!(out, "{}", v[i]),
            Column::U32(v) => write!(out, "{}", v[i]),
            Column::F32(v) => write!(out, "{}", v[i]),
            Column::F64(v) => write!(out, "{}", v[i]),
        };
    }
}

/// The values of one property across an element's rows.
#[derive(Debug, Clone, PartialEq)]
pub enum PropertyData {
    Scalar(Column),
    /// Row `r`'s items are `values[offsets[r]..offsets[r + 1]]`; `offsets` has rows + 1 entries.
    List {
        count_type: ScalarType,
        offsets: Vec<usize>,
        values: Column,
    },
}

#[derive(Debug, Clone, PartialEq)]
pub struct Property {
    pub name: String,
    pub data: PropertyData,
}

impl Property {
    /// A scalar property.
    pub fn scalar(name: impl Into<String>, column: Column) -> Property {
        Property {
            name: name.into(),
            data: PropertyData::Scalar(column),
        }
    }

    /// A list property from per-row item counts' prefix sums (`offsets`, rows + 1 entries, starting at 0).
    pub fn list(
        name: impl Into<String>,
        count_type: ScalarType,
        offsets: Vec<usize>,
        values: Column,
    ) -> Property {
        Property {
            name: name.into(),
            data: PropertyData::List {
                count_type,
                offsets,
                values,
            },
        }
    }

    /// The header declaration of this property.
    fn declaration(&self) -> String {
        match &self.data {
            PropertyData::Scalar(c) => format!("property {} {}", c.scalar_type(), self.name),
            PropertyData::List {
                count_type, values, ..
            } => {
                format!(
                    "property list {} {} {}",
                    count_type,
                    values.scalar_type(),
                    self.name
                )
            }
        }
    }
}

/// A named group of rows (e.g. `vertex`, `face`) with typed columns.
#[derive(Debug, Clone, PartialEq)]
pub struct Element {
    pub name: String,
    pub count: usize,
    pub properties: Vec<Property>,
}

/// A list property converted to one item type.
#[derive(Debug, Clone, PartialEq)]
pub struct List<T> {
    /// Row `r`'s items are `values[offsets[r]..offsets[r + 1]]`.
    pub offsets: Vec<usize>,
    pub values: Vec<T>,
}

impl<T> List<T> {
    pub fn len(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    pub fn row(&self, r: usize) -> &[T] {
        &self.values[self.offsets[r]..self.offsets[r + 1]]
    }

    pub fn rows(&self) -> impl Iterator<Item = &[T]> {
        self.offsets.windows(2).map(|w| &self.values[w[0]..w[1]])
    }
}

/// Types an accessor can convert a column into.
pub trait PlyValue: Sized + Copy {
    const NAME: &'static str;
    /// Converts value `i`; `Err` explains why it does not fit.
    fn convert(column: &Column, i: usize) -> Result<Self, String>;
}

impl PlyValue for f64 {
    const NAME: &'static str = "f64";
    fn convert(column: &Column, i: usize) -> Result<f64, String> {
        Ok(column.get_f64(i))
    }
}

impl PlyValue for f32 {
    const NAME: &'static str = "f32";
    /// Doubles are rounded to the nearest f32 (positions stored as double are common).
    fn convert(column: &Column, i: usize) -> Result<f32, String> {
        Ok(match column {
            Column::F32(v) => v[i],
            other => other.get_f64(i) as f32,
        })
    }
}

macro_rules! integer_value {
    ($t:ty) => {
        impl PlyValue for $t {
            const NAME: &'static str = stringify!($t);
            fn convert(column: &Column, i: usize) -> Result<$t, String> {
                let wide = column.get_i64(i).ok_or_else(|| {
                    format!("is {} but an integer type is needed", column.scalar_type())
                })?;
                <$t>::try_from(wide)
                    .map_err(|_| format!("value {wide} does not fit in {}", stringify!($t)))
            }
        }
    };
}
integer_value!(i8);
integer_value!(u8);
integer_value!(i16);
integer_value!(u16);
integer_value!(i32);
integer_value!(u32);
integer_value!(i64);
integer_value!(u64);
integer_value!(usize);

impl Element {
    pub fn new(name: impl Into<String>, count: usize) -> Element {
        Element {
            name: name.into(),
            count,
            properties: Vec::new(),
        }
    }

    /// Builder: adds a property.
    pub fn with(mut self, property: Property) -> Element {
        self.properties.push(property);
        self
    }

    pub fn property(&self, name: &str) -> Option<&Property> {
        self.properties.iter().find(|p| p.name == name)
    }

    pub fn has(&self, name: &str) -> bool {
        self.property(name).is_some()
    }

    /// The raw column of a scalar property.
    pub fn column(&self, name: &str) -> Result<&Column, String> {
        match self.property(name).map(|p| &p.data) {
            Some(PropertyData::Scalar(c)) => Ok(c),
            Some(PropertyData::List { .. }) => Err(format!(
                "element {:?} property {name:?} is a list, not a scalar",
                self.name
            )),
            None => Err(format!(
                "element {:?} has no property {name:?}{}",
                self.name,
                self.available()
            )),
        }
    }

    /// A scalar property converted to `T` (every value checked to fit).
    pub fn scalar<T: PlyValue>(&self, name: &str) -> Result<Vec<T>, String> {
        let column = self.column(name)?;
        (0..column.len())
            .map(|i| {
                T::convert(column, i).map_err(|e| {
                    format!(
                        "element {:?} row {i} property {name:?}: {e} (as {})",
                        self.name,
                        T::NAME
                    )
                })
            })
            .collect()
    }

    pub fn scalar_f64(&self, name: &str) -> Result<Vec<f64>, String> {
        self.scalar(name)
    }

    pub fn scalar_f32(&self, name: &str) -> Result<Vec<f32>, String> {
        self.scalar(name)
    }

    pub fn scalar_i32(&self, name: &str) -> Result<Vec<i32>, String> {
        self.scalar(name)
    }

    pub fn scalar_u8(&self, name: &str) -> Result<Vec<u8>, String> {
        self.scalar(name)
    }

    /// A list property with its items converted to `T` (every item checked to fit).
    pub fn list<T: PlyValue>(&self, name: &str) -> Result<List<T>, String> {
        let (offsets, values) = match self.property(name).map(|p| &p.data) {
            Some(PropertyData::List {
                offsets, values, ..
            }) => (offsets, values),
            Some(PropertyData::Scalar(_)) => {
                return Err(format!(
                    "element {:?} property {name:?} is a scalar, not a list",
                    self.name
                ));
            }
            None => {
                return Err(format!(
                    "element {:?} has no property {name:?}{}",
                    self.name,
                    self.available()
                ));
            }
        };
        let mut converted = Vec::with_capacity(values.len());
        for (row, w) in offsets.windows(2).enumerate() {
            for i in w[0]..w[1] {
                converted.push(T::convert(values, i).map_err(|e| {
                    format!(
                        "element {:?} row {row} list {name:?} item {}: {e} (as {})",
                        self.name,
                        i - w[0],
                        T::NAME
                    )
                })?);
            }
        }
        Ok(List {
            offsets: offsets.clone(),
            values: converted,
        })
    }

    pub fn list_u32(&self, name: &str) -> Result<List<u32>, String> {
        self.list(name)
    }

    pub fn list_i32(&self, name: &str) -> Result<List<i32>, String> {
        self.list(name)
    }

    fn available(&self) -> String {
        let names: Vec<&str> = self.properties.iter().map(|p| p.name.as_str()).collect();
        format!(" (it has: {})", names.join(", "))
    }

    /// Checks that every column has one entry per row and list offsets are consistent.
    fn check_shape(&self) -> Result<(), String> {
        let mut seen = std::collections::HashSet::new();
        for p in &self.properties {
            if !seen.insert(p.name.as_str()) {
                return Err(format!(
                    "element {:?} has property {:?} twice",
                    self.name, p.name
                ));
            }
            if p.name.is_empty() || p.name.chars().any(char::is_whitespace) {
                return Err(format!(
                    "element {:?} property name {:?} must be one non-empty word",
                    self.name, p.name
                ));
            }
            let where_ = || format!("element {:?} property {:?}", self.name, p.name);
            match &p.data {
                PropertyData::Scalar(c) => {
                    if c.len() != self.count {
                        return Err(format!(
                            "{} has {} values for {} rows",
                            where_(),
                            c.len(),
                            self.count
                        ));
                    }
                }
                PropertyData::List {
                    count_type,
                    offsets,
                    values,
                } => {
                    let Some((_, max_count)) = count_type.integer_range() else {
                        return Err(format!(
                            "{}: list count type {count_type} is not an integer type",
                            where_()
                        ));
                    };
                    if offsets.len() != self.count + 1 || offsets.first() != Some(&0) {
                        return Err(format!(
                            "{}: offsets must have rows + 1 = {} entries starting at 0, found {}",
                            where_(),
                            self.count + 1,
                            offsets.len()
                        ));
                    }
                    for (row, w) in offsets.windows(2).enumerate() {
                        if w[1] < w[0] {
                            return Err(format!("{} row {row}: offsets decrease", where_()));
                        }
                        if (w[1] - w[0]) as u64 > max_count as u64 {
                            return Err(format!(
                                "{} row {row}: {} items do not fit the count type {count_type}",
                                where_(),
                                w[1] - w[0]
                            ));
                        }
                    }
                    if offsets[self.count] != values.len() {
                        return Err(format!(
                            "{}: offsets end at {} but there are {} items",
                            where_(),
                            offsets[self.count],
                            values.len()
                        ));
                    }
                }
            }
        }
        Ok(())
    }
}

/// A whole PLY file in memory.
#[derive(Debug, Clone, PartialEq)]
pub struct Ply {
    /// The format the file was read in (the writer takes its own format argument).
    pub format: Format,
    pub comments: Vec<String>,
    pub obj_info: Vec<String>,
    pub elements: Vec<Element>,
}

impl Default for Ply {
    fn default() -> Ply {
        Ply {
            format: Format::BinaryLittleEndian,
            comments: Vec::new(),
            obj_info: Vec::new(),
            elements: Vec::new(),
        }
    }
}

impl Ply {
    pub fn new(elements: Vec<Element>) -> Ply {
        Ply {
            elements,
            ..Ply::default()
        }
    }

    pub fn element(&self, name: &str) -> Result<&Element, String> {
        self.elements
            .iter()
            .find(|e| e.name == name)
            .ok_or_else(|| {
                let names: Vec<&str> = self.elements.iter().map(|e| e.name.as_str()).collect();
                format!("no element {name:?} (the file has: {})", names.join(", "))
            })
    }

    pub fn has_element(&self, name: &str) -> bool {
        self.elements.iter().any(|e| e.name == name)
    }

    /// Reads a PLY file.
    pub fn read(path: &Path) -> Result<Ply, PlyError> {
        let name = path.display().to_string();
        let bytes =
            std::fs::read(path).map_err(|e| PlyError::new(&name, format!("cannot read: {e}")))?;
        Ply::from_bytes(&bytes, &name)
    }

    /// Parses PLY bytes; `source_name` is used in error messages.
    pub fn from_bytes(bytes: &[u8], source_name: &str) -> Result<Ply, PlyError> {
        let err = |m: String| PlyError::new(source_name, m);
        let header = parse_header(bytes).map_err(err)?;
        let mut ply = Ply {
            format: header.format,
            comments: header.comments,
            obj_info: header.obj_info,
            elements: Vec::with_capacity(header.elements.len()),
        };
        let body = &bytes[header.body_start..];
        let (declared, base, out) = (&header.elements, header.body_start, &mut ply.elements);
        match header.format {
            Format::Ascii => {
                let tokens = Tokens { text: body, pos: 0 };
                read_body(declared, base, &mut AsciiDecoder { tokens }, out)
            }
            Format::BinaryLittleEndian | Format::BinaryBigEndian => {
                let big_endian = header.format == Format::BinaryBigEndian;
                let mut decoder = BinaryDecoder {
                    body,
                    pos: 0,
                    big_endian,
                };
                read_body(declared, base, &mut decoder, out)
            }
        }
        .map_err(err)?;
        Ok(ply)
    }

    /// Encodes the file in `format`, after checking every element's shape.
    pub fn to_bytes(&self, format: Format) -> Result<Vec<u8>, String> {
        let mut seen = std::collections::HashSet::new();
        for e in &self.elements {
            if !seen.insert(e.name.as_str()) {
                return Err(format!("element {:?} appears twice", e.name));
            }
            if e.name.is_empty() || e.name.chars().any(char::is_whitespace) {
                return Err(format!(
                    "element name {:?} must be one non-empty word",
                    e.name
                ));
            }
            e.check_shape()?;
        }
        for line in self.comments.iter().chain(&self.obj_info) {
            if line.contains(['\n', '\r']) {
                return Err(format!("comment {line:?} spans several lines"));
            }
        }
        let mut out = Vec::new();
        out.extend_from_slice(b"ply\n");
        out.extend_from_slice(format!("format {} 1.0\n", format.keyword()).as_bytes());
        for c in &self.comments {
            out.extend_from_slice(format!("comment {c}\n").as_bytes());
        }
        for c in &self.obj_info {
            out.extend_from_slice(format!("obj_info {c}\n").as_bytes());
        }
        for e in &self.elements {
            out.extend_from_slice(format!("element {} {}\n", e.name, e.count).as_bytes());
            for p in &e.properties {
                out.extend_from_slice(p.declaration().as_bytes());
                out.push(b'\n');
            }
        }
        out.extend_from_slice(b"end_header\n");
        match format {
            Format::Ascii => {
                let mut line = String::new();
                for e in &self.elements {
                    for row in 0..e.count {
                        line.clear();
                        for p in &e.properties {
                            if !line.is_empty() {
                                line.push(' ');
                            }
                            match &p.data {
                                PropertyData::Scalar(c) => c.write_ascii(row, &mut line),
                                PropertyData::List {
                                    offsets, values, ..
                                } => {
                                    let (a, b) = (offsets[row], offsets[row + 1]);
                                    line.push_str(&(b - a).to_string());
                                    for i in a..b {
                                        line.push(' ');
                                        values.write_ascii(i, &mut line);
                                    }
                                }
                            }
                        }
                        line.push('\n');
                        out.extend_from_slice(line.as_bytes());
                    }
                }
            }
            Format::BinaryLittleEndian | Format::BinaryBigEndian => {
                let big = format == Format::BinaryBigEndian;
                for e in &self.elements {
                    for row in 0..e.count {
                        for p in &e.properties {
                            match &p.data {
                                PropertyData::Scalar(c) => c.write_binary(row, big, &mut out),
                                PropertyData::List {
                                    count_type,
                                    offsets,
                                    values,
                                } => {
                                    let (a, b) = (offsets[row], offsets[row + 1]);
                                    write_count(*count_type, b - a, big, &mut out);
                                    for i in a..b {
                                        values.write_binary(i, big, &mut out);
                                    }
                                }
                            }
                        }
                    }
                }
            }
        }
        Ok(out)
    }

    /// Writes the file in `format`.
    pub fn write(&self, path: &Path, format: Format) -> Result<(), PlyError> {
        let name = path.display().to_string();
        let bytes = self.to_bytes(format).map_err(|m| PlyError::new(&name, m))?;
        let mut file = std::fs::File::create(path)
            .map_err(|e| PlyError::new(&name, format!("cannot create: {e}")))?;
        file.write_all(&bytes)
            .map_err(|e| PlyError::new(&name, format!("cannot write: {e}")))
    }
}

/// Writes a list count already checked (by `check_shape`) to fit `ty`.
fn write_count(ty: ScalarType, n: usize, big: bool, out: &mut Vec<u8>) {
    let col = match ty {
        ScalarType::I8 => Column::I8(vec![n as i8]),
        ScalarType::U8 => Column::U8(vec![n as u8]),
        ScalarType::I16 => Column::I16(vec![n as i16]),
        ScalarType::U16 => Column::U16(vec![n as u16]),
        ScalarType::I32 => Column::I32(vec![n as i32]),
        ScalarType::U32 => Column::U32(vec![n as u32]),
        // check_shape refuses float count types before any byte is written.
        ScalarType::F32 | ScalarType::F64 => {
            unreachable!("float list counts are refused by check_shape")
        }
    };
    col.write_binary(0, big, out);
}

/// A property as declared in the header.
#[derive(Debug, Clone)]
enum Declared {
    Scalar(ScalarType),
    List { count: ScalarType, item: ScalarType },
}

#[derive(Debug, Clone)]
struct DeclaredElement {
    name: String,
    count: usize,
    properties: Vec<(String, Declared)>,
}

struct Header {
    format: Format,
    comments: Vec<String>,
    obj_info: Vec<String>,
    elements: Vec<DeclaredElement>,
    body_start: usize,
}

fn parse_header(bytes: &[u8]) -> Result<Header, String> {
    let mut pos = 0usize;
    let mut line_no = 0usize;
    let mut format = None;
    let mut comments = Vec::new();
    let mut obj_info = Vec::new();
    let mut elements: Vec<DeclaredElement> = Vec::new();
    loop {
        if pos >= bytes.len() {
            return Err(format!("header ends at byte {pos} without `end_header`"));
        }
        let end = bytes[pos..]
            .iter()
            .position(|&b| b == b'\n')
            .map(|i| pos + i);
        let Some(end) = end else {
            return Err(format!(
                "header ends at byte {} without `end_header`",
                bytes.len()
            ));
        };
        let raw = &bytes[pos..end];
        let raw = raw.strip_suffix(b"\r").unwrap_or(raw);
        let line_start = pos;
        pos = end + 1;
        line_no += 1;
        let line = std::str::from_utf8(raw)
            .map_err(|_| format!("header line {line_no} (byte {line_start}) is not text"))?;
        let at = || format!("header line {line_no} (byte {line_start})");
        if line_no == 1 {
            if line.trim_end() != "ply" {
                return Err(format!(
                    "not a PLY file: first line is {:?}, expected \"ply\"",
                    truncate(line)
                ));
            }
            continue;
        }
        let mut words = line.split_whitespace();
        let Some(keyword) = words.next() else {
            continue;
        };
        match keyword {
            "format" => {
                let f = match words.next() {
                    Some("ascii") => Format::Ascii,
                    Some("binary_little_endian") => Format::BinaryLittleEndian,
                    Some("binary_big_endian") => Format::BinaryBigEndian,
                    other => {
                        return Err(format!(
                            "{}: unknown format {:?}",
                            at(),
                            other.unwrap_or("")
                        ));
                    }
                };
                if format.replace(f).is_some() {
                    return Err(format!("{}: second `format` line", at()));
                }
            }
            "comment" => comments.push(rest_after(line, "comment")),
            "obj_info" => obj_info.push(rest_after(line, "obj_info")),
            "element" => {
                let (Some(name), Some(count), None) = (words.next(), words.next(), words.next())
                else {
                    return Err(format!(
                        "{}: expected `element <name> <count>`, found {:?}",
                        at(),
                        truncate(line)
                    ));
                };
                let count: usize = count.parse().map_err(|_| {
                    format!("{}: element {name:?} count {count:?} is not a count", at())
                })?;
                if elements.iter().any(|e| e.name == name) {
                    return Err(format!("{}: element {name:?} declared twice", at()));
                }
                elements.push(DeclaredElement {
                    name: name.to_string(),
                    count,
                    properties: Vec::new(),
                });
            }
            "property" => {
                let Some(element) = elements.last_mut() else {
                    return Err(format!("{}: property before any element", at()));
                };
                let ty = |w: Option<&str>| -> Result<ScalarType, String> {
                    let w = w.unwrap_or("");
                    ScalarType::parse(w).ok_or_else(|| {
                        format!(
                            "{}: element {:?}: unknown property type {w:?}",
                            at(),
                            element.name
                        )
                    })
                };
                let first = words.next();
                let (decl, name) = if first == Some("list") {
                    let count = ty(words.next())?;
                    let item = ty(words.next())?;
                    if !count.is_integer() {
                        return Err(format!(
                            "{}: element {:?}: list count type {count} is not an integer type",
                            at(),
                            element.name
                        ));
                    }
                    (Declared::List { count, item }, words.next())
                } else {
                    (Declared::Scalar(ty(first)?), words.next())
                };
                let (Some(name), None) = (name, words.next()) else {
                    return Err(format!(
                        "{}: expected one property name in {:?}",
                        at(),
                        truncate(line)
                    ));
                };
                if element.properties.iter().any(|(n, _)| n == name) {
                    return Err(format!(
                        "{}: element {:?} declares property {name:?} twice",
                        at(),
                        element.name
                    ));
                }
                element.properties.push((name.to_string(), decl));
            }
            "end_header" => break,
            other => {
                return Err(format!(
                    "{}: unknown header keyword {:?}",
                    at(),
                    truncate(other)
                ));
            }
        }
    }
    let format = format.ok_or("header has no `format` line")?;
    Ok(Header {
        format,
        comments,
        obj_info,
        elements,
        body_start: pos,
    })
}

fn rest_after(line: &str, keyword: &str) -> String {
    let rest = line.trim_start().strip_prefix(keyword).unwrap_or("");
    rest.strip_prefix(' ').unwrap_or(rest).to_string()
}

fn truncate(s: &str) -> String {
    s.chars().take(60).collect()
}

fn empty_property(name: &str, decl: &Declared, capacity: usize) -> Property {
    let data = match decl {
        Declared::Scalar(t) => PropertyData::Scalar(Column::empty(*t, capacity)),
        Declared::List { count, item } => {
            let mut offsets = Vec::with_capacity(capacity + 1);
            offsets.push(0);
            PropertyData::List {
                count_type: *count,
                offsets,
                values: Column::empty(*item, 0),
            }
        }
    };
    Property {
        name: name.to_string(),
        data,
    }
}

/// Where a value of the body sits, for error messages.
struct At<'a> {
    element: &'a str,
    row: usize,
    property: &'a str,
    /// Offset of the body in the file.
    base: usize,
}

impl At<'_> {
    /// `message`, naming the element, row, property and the file offset of body byte `pos`.
    fn fail(&self, pos: usize, message: impl fmt::Display) -> String {
        format!(
            "element {:?} row {} property {:?} at byte {}: {message}",
            self.element,
            self.row,
            self.property,
            self.base + pos
        )
    }
}

/// The part of a property a value is read for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Slot {
    Value,
    ListCount,
    ListItem,
}

impl Slot {
    fn noun(self) -> &'static str {
        match self {
            Slot::Value => "value",
            Slot::ListCount => "list count",
            Slot::ListItem => "list item",
        }
    }
}

/// One encoding of a PLY body, read one value at a time.
trait BodyDecoder {
    /// Refuses `d.count` rows when the rest of the body cannot hold them (before anything
    /// is allocated for them); otherwise says how many rows to reserve.
    fn capacity(&self, d: &DeclaredElement, base: usize) -> Result<usize, String>;

    /// Appends the next value, of `col`'s type, to `col`; returns the body offset it
    /// starts at.
    fn read(&mut self, col: &mut Column, slot: Slot, at: &At) -> Result<usize, String>;

    /// Refuses a list of `len` `item`s, its count read at body offset `count_pos`, when
    /// the rest of the body cannot hold it. Without a check here each item must still
    /// come from real data, so nothing is reserved from `len`.
    fn check_list(
        &self,
        _len: i64,
        _item: ScalarType,
        _count_pos: usize,
        _at: &At,
    ) -> Result<(), String> {
        Ok(())
    }
}

/// Reads the rows of every declared element from `decoder`; `base` is the body's offset
/// in the file.
fn read_body(
    declared: &[DeclaredElement],
    base: usize,
    decoder: &mut impl BodyDecoder,
    out: &mut Vec<Element>,
) -> Result<(), String> {
    for d in declared {
        let capacity = decoder.capacity(d, base)?;
        let mut props: Vec<Property> = d
            .properties
            .iter()
            .map(|(n, p)| empty_property(n, p, capacity))
            .collect();
        // Rows of an element without properties hold nothing: walking a huge declared
        // count of them would only spin.
        let rows = if d.properties.is_empty() { 0 } else { d.count };
        for row in 0..rows {
            for (prop, (name, decl)) in props.iter_mut().zip(&d.properties) {
                let at = At {
                    element: &d.name,
                    row,
                    property: name,
                    base,
                };
                match (&mut prop.data, decl) {
                    (PropertyData::Scalar(col), Declared::Scalar(_)) => {
                        decoder.read(col, Slot::Value, &at)?;
                    }
                    (
                        PropertyData::List {
                            offsets, values, ..
                        },
                        Declared::List { count, item },
                    ) => {
                        let mut c = Column::empty(*count, 1);
                        let count_pos = decoder.read(&mut c, Slot::ListCount, &at)?;
                        // `count` is an integer type (checked in the header), so get_i64 is Some.
                        let len = c.get_i64(0).unwrap_or(-1);
                        if len < 0 {
                            return Err(at.fail(count_pos, format!("negative list count {len}")));
                        }
                        decoder.check_list(len, *item, count_pos, &at)?;
                        for _ in 0..len {
                            decoder.read(values, Slot::ListItem, &at)?;
                        }
                        offsets.push(values.len());
                    }
                    // Properties are built from the same declarations they are zipped with.
                    _ => unreachable!("property storage mirrors its declaration"),
                }
            }
        }
        out.push(Element {
            name: d.name.clone(),
            count: d.count,
            properties: props,
        });
    }
    Ok(())
}

/// A `binary_little_endian` or `binary_big_endian` body.
struct BinaryDecoder<'a> {
    body: &'a [u8],
    pos: usize,
    big_endian: bool,
}

impl BodyDecoder for BinaryDecoder<'_> {
    fn capacity(&self, d: &DeclaredElement, base: usize) -> Result<usize, String> {
        // The smallest number of bytes one row can occupy.
        let min_row: usize = d
            .properties
            .iter()
            .map(|(_, p)| match p {
                Declared::Scalar(t) => t.size(),
                Declared::List { count, .. } => count.size(),
            })
            .sum();
        let remaining = self.body.len() - self.pos;
        if min_row > 0 && d.count > remaining / min_row {
            return Err(format!(
                "element {:?} declares {} rows of at least {min_row} bytes but only {remaining} bytes remain at byte {}",
                d.name,
                d.count,
                base + self.pos
            ));
        }
        Ok(if min_row > 0 { d.count } else { 0 })
    }

    fn read(&mut self, col: &mut Column, slot: Slot, at: &At) -> Result<usize, String> {
        let start = self.pos;
        let t = col.scalar_type();
        let n = t.size();
        let bytes = self.body.get(start..start + n).ok_or_else(|| match slot {
            Slot::ListCount => at.fail(start, "file ends inside the list count"),
            // (List items never get here: `check_list` has seen the bytes for all of them.)
            Slot::Value | Slot::ListItem => {
                at.fail(start, format!("file ends (a {t} needs {n} bytes)"))
            }
        })?;
        col.push_bytes(bytes, self.big_endian);
        self.pos += n;
        Ok(start)
    }

    fn check_list(
        &self,
        len: i64,
        item: ScalarType,
        count_pos: usize,
        at: &At,
    ) -> Result<(), String> {
        let need = (len as u64).saturating_mul(item.size() as u64);
        let left = (self.body.len() - self.pos) as u64;
        if need > left {
            return Err(at.fail(
                count_pos,
                format!("list of {len} {item} items needs {need} bytes but only {left} remain"),
            ));
        }
        Ok(())
    }
}

/// Splits ASCII text into whitespace-separated tokens, remembering where each starts.
struct Tokens<'a> {
    text: &'a [u8],
    pos: usize,
}

impl<'a> Tokens<'a> {
    fn next(&mut self) -> Option<(usize, &'a [u8])> {
        while self.pos < self.text.len() && self.text[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        if self.pos >= self.text.len() {
            return None;
        }
        let start = self.pos;
        while self.pos < self.text.len() && !self.text[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        Some((start, &self.text[start..self.pos]))
    }
}

/// An `ascii` body: one whitespace-separated token a value.
struct AsciiDecoder<'a> {
    tokens: Tokens<'a>,
}

impl BodyDecoder for AsciiDecoder<'_> {
    fn capacity(&self, d: &DeclaredElement, base: usize) -> Result<usize, String> {
        // Every property of every row needs at least one token of one byte plus a separator.
        let remaining = self.tokens.text.len() - self.tokens.pos;
        let per_row = d.properties.len();
        if per_row > 0 && d.count > (remaining / 2 + 1) / per_row {
            return Err(format!(
                "element {:?} declares {} rows of {per_row} values but only {remaining} bytes remain at byte {}",
                d.name,
                d.count,
                base + self.tokens.pos
            ));
        }
        Ok(if per_row > 0 { d.count } else { 0 })
    }

    fn read(&mut self, col: &mut Column, slot: Slot, at: &At) -> Result<usize, String> {
        let here = at.base + self.tokens.pos;
        let (start, tok) = self.tokens.next().ok_or_else(|| {
            format!(
                "element {:?} row {} property {:?}: file ends at byte {here} before its {}",
                at.element,
                at.row,
                at.property,
                slot.noun()
            )
        })?;
        let tok = std::str::from_utf8(tok).map_err(|_| at.fail(start, "not text"))?;
        col.push_token(tok).map_err(|e| at.fail(start, e))?;
        Ok(start)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Ply {
        let vertex = Element::new("vertex", 3)
            .with(Property::scalar("y", Column::F64(vec![0.5, -1.25, 1e-300])))
            .with(Property::scalar(
                "x",
                Column::F32(vec![1.0, f32::MIN_POSITIVE, -3.5]),
            ))
            .with(Property::scalar("flag", Column::I8(vec![-128, 0, 127])))
            .with(Property::scalar("id", Column::U32(vec![0, u32::MAX, 7])));
        let face = Element::new("face", 2).with(Property::list(
            "vertex_indices",
            ScalarType::U8,
            vec![0, 3, 7],
            Column::I32(vec![0, 1, 2, 2, 1, 0, 1]),
        ));
        Ply {
            comments: vec!["made by a test".into()],
            obj_info: vec!["info line".into()],
            ..Ply::new(vec![vertex, face])
        }
    }

    #[test]
    fn every_format_round_trips_exactly() {
        let ply = sample();
        for format in [
            Format::Ascii,
            Format::BinaryLittleEndian,
            Format::BinaryBigEndian,
        ] {
            let bytes = ply.to_bytes(format).unwrap();
            let back = Ply::from_bytes(&bytes, "mem").unwrap();
            assert_eq!(
                back,
                Ply {
                    format,
                    ..ply.clone()
                },
                "{format:?}"
            );
        }
    }

    #[test]
    fn an_element_without_properties_keeps_its_count_without_walking_it() {
        for format in ["ascii", "binary_little_endian"] {
            let text = format!(
                "ply\nformat {format} 1.0\nelement empty 99999999999\nelement vertex 1\nproperty uchar v\nend_header\n"
            );
            let mut bytes = text.into_bytes();
            bytes.extend_from_slice(if format == "ascii" { b"7\n" } else { &[7] });
            let ply = Ply::from_bytes(&bytes, "mem").unwrap();
            assert_eq!(ply.element("empty").unwrap().count, 99_999_999_999);
            let v = ply.element("vertex").unwrap().scalar_f64("v").unwrap();
            assert_eq!(v, vec![7.0], "{format}");
        }
    }

    #[test]
    fn accessors_convert_and_check_ranges() {
        let ply = sample();
        let v = ply.element("vertex").unwrap();
        assert_eq!(v.scalar_f64("flag").unwrap(), vec![-128.0, 0.0, 127.0]);
        assert!(v.scalar_u8("flag").unwrap_err().contains("row 0"));
        assert!(v.scalar_i32("x").unwrap_err().contains("float"));
        let f = ply
            .element("face")
            .unwrap()
            .list_u32("vertex_indices")
            .unwrap();
        assert_eq!(f.row(1), &[2, 1, 0, 1]);
        assert!(ply.element("edge").unwrap_err().contains("vertex, face"));
    }

    #[test]
    fn writer_refuses_counts_that_do_not_fit_the_count_type() {
        let e = Element::new("face", 1).with(Property::list(
            "vertex_indices",
            ScalarType::I8,
            vec![0, 200],
            Column::U8(vec![0; 200]),
        ));
        assert!(
            Ply::new(vec![e])
                .to_bytes(Format::BinaryLittleEndian)
                .unwrap_err()
                .contains("count type char")
        );
    }
}
