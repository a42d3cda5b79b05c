//! Hair from pbrt-v4 scene files: every `Shape "curve"` becomes a strand (design: a polyline; the
//! pbrt-v4 scene format, pbrt.org/fileformat-v4, "Curves").
//!
//! Read: `"point3 P"` (also v3's `"point P"`), `"float width"` or `"width0"`/`"width1"` (default
//! 1; the width runs linearly from width0 to width1 over the curve's segments, as pbrt-v4's
//! `Curve::Create` gives each segment `lerp(seg / n)` to `lerp((seg + 1) / n)`), `"integer degree"`
//! (2 or 3, default 3), `"string basis"` (`bezier`, the default, or uniform `bspline`) and
//! `"string type"` (`flat`, the default, `cylinder` or `ribbon`: all become round fibers here, of
//! radius width / 2). A Bezier curve of degree d holds d + 1 + k d control points (k >= 0), one
//! segment per d after the first point; a B-spline holds n >= d + 1 points and n - d segments,
//! each turned into its Bezier form, then cut into straight pieces (`curves.rs`).
//!
//! The transform in force at each shape applies (`Translate`, `Scale`, `Rotate`, `LookAt`,
//! `Transform`, `ConcatTransform`, `Identity`, inside `AttributeBegin`/`AttributeEnd`;
//! `WorldBegin` resets it; widths scale by the cube root of its determinant), `Include` and
//! `Import` are followed (paths relative to the first file's folder, as pbrt does; `.gz` files are
//! decompressed), and every other directive is skipped with its parameters (named coordinate
//! systems are not followed). Instanced curves (inside `ObjectBegin`/`ObjectEnd`) are refused.
//! Errors name the file and line.

use super::Strands;
use super::curves::{append_strand, bspline_to_bezier, lerp};
use glam::{DMat4, DVec3};
use std::io::Read;
use std::path::{Path, PathBuf};

/// A pbrt file that cannot be read as hair; the message names the file and line.
#[derive(Debug, thiserror::Error)]
pub enum PbrtError {
    #[error("cannot read {}: {error}", path.display())]
    Io { path: PathBuf, error: std::io::Error },
    #[error("{}:{line}: {problem}", path.display())]
    At { path: PathBuf, line: usize, problem: String },
    #[error("{}: holds no `Shape \"curve\"`", path.display())]
    NoCurves { path: PathBuf },
}

/// How deep `Include`s may nest (a file that includes itself stops here).
const MAX_INCLUDE_DEPTH: usize = 32;

/// Reads every `Shape "curve"` of a pbrt-v4 scene file (and the files it includes) as strands,
/// in world space.
pub fn read_pbrt_curves(path: &Path) -> Result<Strands, PbrtError> {
    parse_pbrt_curves(path, &read_file)
}

/// The bytes of a file, decompressed when its name ends in `.gz`.
fn read_file(path: &Path) -> std::io::Result<Vec<u8>> {
    let file = std::io::BufReader::new(std::fs::File::open(path)?);
    let mut bytes = Vec::new();
    if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("gz")) {
        flate2::read::MultiGzDecoder::new(file).read_to_end(&mut bytes)?;
    } else {
        { file }.read_to_end(&mut bytes)?;
    }
    Ok(bytes)
}

/// [`read_pbrt_curves`] with the files' bytes from `read` (the fuzz target's files live in
/// memory).
pub fn parse_pbrt_curves(path: &Path, read: &dyn Fn(&Path) -> std::io::Result<Vec<u8>>) -> Result<Strands, PbrtError> {
    let root = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let mut reader = Reader {
        root,
        read,
        reading: Vec::new(),
        state: State::default(),
        stack: Vec::new(),
        strands: Strands::default(),
    };
    reader.strands.offsets.push(0);
    reader.file(path, 0)?;
    if reader.strands.strand_count() == 0 {
        return Err(PbrtError::NoCurves { path: path.to_owned() });
    }
    Ok(reader.strands)
}

/// The graphics state that shapes read.
#[derive(Clone, Default)]
struct State {
    /// The current transform: world from object.
    ctm: Ctm,
    /// Inside `ObjectBegin` ... `ObjectEnd`.
    in_object: bool,
}

#[derive(Clone, Copy)]
struct Ctm(DMat4);

impl Default for Ctm {
    fn default() -> Self {
        Ctm(DMat4::IDENTITY)
    }
}

struct Reader<'a> {
    root: PathBuf,
    read: &'a dyn Fn(&Path) -> std::io::Result<Vec<u8>>,
    /// The files being read, outermost first: an `Include` of one of them is a cycle, which
    /// would otherwise repeat until the nesting limit, 2^31 times where a file includes itself
    /// twice.
    reading: Vec<PathBuf>,
    state: State,
    stack: Vec<State>,
    strands: Strands,
}

/// One token of a pbrt file, with its line.
#[derive(Debug, Clone, PartialEq)]
enum Token {
    Word(String),
    Str(String),
    Number(f64),
    Open,
    Close,
}

/// Splits pbrt text into tokens: bare words and numbers, quoted strings, brackets; `#` starts a
/// comment to the end of the line.
struct Tokens<'a> {
    text: &'a [u8],
    at: usize,
    line: usize,
}

impl Tokens<'_> {
    fn next(&mut self) -> Result<Option<(Token, usize)>, String> {
        let t = self.text;
        loop {
            match t.get(self.at) {
                None => return Ok(None),
                Some(b'\n') => {
                    self.line += 1;
                    self.at += 1;
                }
                Some(c) if c.is_ascii_whitespace() => self.at += 1,
                Some(b'#') => {
                    while self.at < t.len() && t[self.at] != b'\n' {
                        self.at += 1;
                    }
                }
                Some(_) => break,
            }
        }
        let (start, line) = (self.at, self.line);
        let token = match t[start] {
            b'[' => {
                self.at += 1;
                Token::Open
            }
            b']' => {
                self.at += 1;
                Token::Close
            }
            b'"' => {
                let mut s = Vec::new();
                self.at += 1;
                loop {
                    match t.get(self.at) {
                        None | Some(b'\n') => return Err("a string is not closed on its line".into()),
                        Some(b'"') => break,
                        Some(b'\\') => {
                            self.at += 1;
                            s.push(match t.get(self.at) {
                                Some(b'n') => b'\n',
                                Some(b't') => b'\t',
                                Some(&c) => c,
                                None => return Err("a string ends in a backslash".into()),
                            });
                        }
                        Some(&c) => s.push(c),
                    }
                    self.at += 1;
                }
                self.at += 1;
                Token::Str(String::from_utf8(s).map_err(|_| "a string is not UTF-8")?)
            }
            _ => {
                while self.at < t.len() && !t[self.at].is_ascii_whitespace() && !b"[]\"#".contains(&t[self.at]) {
                    self.at += 1;
                }
                let word = std::str::from_utf8(&t[start..self.at]).map_err(|_| "a word is not UTF-8")?;
                let first = word.as_bytes()[0];
                match word.parse::<f64>() {
                    Ok(v) if v.is_finite() => Token::Number(v),
                    // `nan`, `inf`: Rust reads them as numbers, and they are none.
                    Ok(_) => return Err(format!("`{word}` is not a finite number")),
                    Err(_) if first.is_ascii_digit() || b"+-.".contains(&first) => {
                        return Err(format!("`{word}` is not a number"));
                    }
                    Err(_) => Token::Word(word.to_owned()),
                }
            }
        };
        Ok(Some((token, line)))
    }
}

/// A shape's or directive's parameter: its type, name and values.
struct Param {
    kind: String,
    name: String,
    values: Vec<Token>,
}

/// A directive's arguments: the plain values after it, then its `"type name" value` parameters.
struct Args {
    values: Vec<Token>,
    params: Vec<Param>,
}

impl Args {
    fn numbers(&self, n: usize, directive: &str) -> Result<Vec<f64>, String> {
        let v: Vec<f64> =
            self.values.iter().filter_map(|t| if let Token::Number(x) = t { Some(*x) } else { None }).collect();
        if v.len() != n || self.values.len() != n {
            return Err(format!("`{directive}` takes {n} numbers"));
        }
        Ok(v)
    }

    fn string(&self, directive: &str) -> Result<&str, String> {
        match self.values.as_slice() {
            [Token::Str(s)] => Ok(s),
            _ => Err(format!("`{directive}` takes one quoted string")),
        }
    }

    fn param(&self, name: &str) -> Option<&Param> {
        self.params.iter().find(|p| p.name == name)
    }

    fn floats(&self, name: &str) -> Result<Option<Vec<f64>>, String> {
        let Some(p) = self.param(name) else { return Ok(None) };
        p.values
            .iter()
            .map(|t| match t {
                Token::Number(x) => Ok(*x),
                _ => Err(format!("\"{} {name}\" must hold numbers", p.kind)),
            })
            .collect::<Result<Vec<_>, _>>()
            .map(Some)
    }

    fn one_float(&self, name: &str, default: f64) -> Result<f64, String> {
        match self.floats(name)?.as_deref() {
            None => Ok(default),
            Some([x]) => Ok(*x),
            Some(_) => Err(format!("\"{name}\" must hold one number")),
        }
    }

    fn one_string(&self, name: &str, default: &str) -> Result<String, String> {
        match self.param(name).map(|p| p.values.as_slice()) {
            None => Ok(default.to_owned()),
            Some([Token::Str(s)]) => Ok(s.clone()),
            Some(_) => Err(format!("\"{name}\" must hold one string")),
        }
    }
}

impl Reader<'_> {
    fn file(&mut self, path: &Path, depth: usize) -> Result<(), PbrtError> {
        let bytes = (self.read)(path).map_err(|error| PbrtError::Io { path: path.to_owned(), error })?;
        self.reading.push(path.to_owned());
        self.tokens(path, &bytes, depth)?;
        self.reading.pop();
        Ok(())
    }

    fn tokens(&mut self, path: &Path, bytes: &[u8], depth: usize) -> Result<(), PbrtError> {
        let mut tokens = Tokens { text: bytes, at: 0, line: 1 };
        let at = |line: usize, problem: String| PbrtError::At { path: path.to_owned(), line, problem };
        let mut pending = tokens.next().map_err(|p| at(tokens.line, p))?;
        while let Some((token, line)) = pending.take() {
            let Token::Word(directive) = token else {
                return Err(at(line, format!("expected a directive, found {}", describe(&token))));
            };
            // The directive's arguments run to the next bare word (true/false are values).
            let mut values = Vec::new();
            loop {
                let next = tokens.next().map_err(|p| at(tokens.line, p))?;
                match next {
                    Some((Token::Word(w), l)) if w != "true" && w != "false" => {
                        pending = Some((Token::Word(w), l));
                        break;
                    }
                    Some((t, _)) => values.push(t),
                    None => break,
                }
            }
            let args = arguments(values).map_err(|p| at(line, p))?;
            self.directive(&directive, &args, depth).map_err(|e| match e {
                Directive::Problem(p) => at(line, p),
                Directive::Nested(e) => e,
            })?;
        }
        Ok(())
    }

    fn directive(&mut self, name: &str, args: &Args, depth: usize) -> Result<(), Directive> {
        let ctm = &mut self.state.ctm.0;
        match name {
            "AttributeBegin" | "TransformBegin" | "ObjectBegin" => {
                self.stack.push(self.state.clone());
                if name == "ObjectBegin" {
                    self.state.in_object = true;
                }
            }
            "AttributeEnd" | "TransformEnd" | "ObjectEnd" => {
                self.state =
                    self.stack.pop().ok_or_else(|| Directive::Problem(format!("`{name}` without a matching begin")))?;
            }
            "WorldBegin" | "Identity" => *ctm = DMat4::IDENTITY,
            "Translate" => {
                let v = args.numbers(3, name)?;
                *ctm *= DMat4::from_translation(DVec3::new(v[0], v[1], v[2]));
            }
            "Scale" => {
                let v = args.numbers(3, name)?;
                *ctm *= DMat4::from_scale(DVec3::new(v[0], v[1], v[2]));
            }
            "Rotate" => {
                let v = args.numbers(4, name)?;
                let axis = DVec3::new(v[1], v[2], v[3]);
                if axis.length_squared() == 0.0 {
                    return Err(Directive::Problem("`Rotate` about a zero axis".into()));
                }
                *ctm *= DMat4::from_axis_angle(axis.normalize(), v[0].to_radians());
            }
            "LookAt" => {
                let v = args.numbers(9, name)?;
                let (eye, look, up) =
                    (DVec3::new(v[0], v[1], v[2]), DVec3::new(v[3], v[4], v[5]), DVec3::new(v[6], v[7], v[8]));
                // pbrt's LookAt is left-handed: camera space looks down +z.
                let dir = (look - eye).normalize();
                let right = up.normalize().cross(dir);
                if !right.is_finite() || right.length_squared() == 0.0 {
                    return Err(Directive::Problem("`LookAt` with the up vector along the view".into()));
                }
                let right = right.normalize();
                let new_up = dir.cross(right);
                let world_from_camera =
                    DMat4::from_cols(right.extend(0.0), new_up.extend(0.0), dir.extend(0.0), eye.extend(1.0));
                *ctm *= world_from_camera.inverse();
            }
            "Transform" | "ConcatTransform" => {
                let m = matrix(args, name)?;
                *ctm = if name == "Transform" { m } else { *ctm * m };
            }
            "Include" | "Import" => {
                let file = self.root.join(args.string(name)?);
                if self.reading.contains(&file) {
                    return Err(Directive::Problem(format!("{} includes itself (an include cycle)", file.display())));
                }
                if depth + 1 >= MAX_INCLUDE_DEPTH {
                    return Err(Directive::Problem(format!("includes nest more than {MAX_INCLUDE_DEPTH} deep")));
                }
                self.file(&file, depth + 1).map_err(|e| match e {
                    // A file that cannot be opened is this line's problem.
                    PbrtError::Io { path, error } if path == file => {
                        Directive::Problem(format!("cannot read {}: {error}", path.display()))
                    }
                    e => Directive::Nested(e),
                })?;
            }
            "Shape" => match args.values.as_slice() {
                [Token::Str(kind)] if kind == "curve" => {
                    if self.state.in_object {
                        return Err(Directive::Problem(
                            "a curve inside ObjectBegin ... ObjectEnd: instanced hair is not supported".into(),
                        ));
                    }
                    self.curve(args).map_err(Directive::Problem)?;
                }
                [Token::Str(_)] => {}
                _ => return Err(Directive::Problem("`Shape` needs its type as one quoted string".into())),
            },
            // Camera, Film, Material, LightSource and the rest do not move curves (named
            // coordinate systems are rare in hair files and not followed).
            _ => {}
        }
        Ok(())
    }

    /// One `Shape "curve"`: appended as a strand.
    fn curve(&mut self, args: &Args) -> Result<(), String> {
        let p = match (args.floats("P")?, args.param("P").map(|p| p.kind.as_str())) {
            (Some(p), Some("point3" | "point")) => p,
            (Some(_), Some(kind)) => return Err(format!("\"{kind} P\": curve points are \"point3 P\"")),
            _ => return Err("a curve needs \"point3 P\"".into()),
        };
        if p.len() % 3 != 0 {
            return Err(format!("\"point3 P\" holds {} numbers, not a multiple of 3", p.len()));
        }
        let cp: Vec<DVec3> =
            p.chunks_exact(3).map(|c| self.state.ctm.0.transform_point3(DVec3::new(c[0], c[1], c[2]))).collect();
        let width = args.one_float("width", 1.0)?;
        let (w0, w1) = (args.one_float("width0", width)?, args.one_float("width1", width)?);
        if !(w0 > 0.0 && w1 > 0.0) {
            return Err(format!("curve widths must be > 0, got {w0} and {w1}"));
        }
        // Widths are in object space: scaled by the transform (its mean axis scale).
        let scale = (self.state.ctm.0.determinant().abs()).cbrt();
        let degree = match args.floats("degree")?.as_deref() {
            None => 3,
            Some([d]) if *d == 2.0 || *d == 3.0 => *d as usize,
            Some(d) => return Err(format!("\"integer degree\" must be 2 or 3, got {d:?}")),
        };
        let basis = args.one_string("basis", "bezier")?;
        let kind = args.one_string("type", "flat")?;
        if !["flat", "cylinder", "ribbon"].contains(&kind.as_str()) {
            return Err(format!("unknown curve type \"{kind}\" (flat, cylinder or ribbon)"));
        }
        let n = cp.len();
        let segments: Vec<Vec<DVec3>> = match basis.as_str() {
            "bezier" => {
                if n < degree + 1 || !(n - 1).is_multiple_of(degree) {
                    return Err(format!(
                        "{n} control points: a degree {degree} Bezier curve takes {} + k * {degree} (k >= 0)",
                        degree + 1
                    ));
                }
                (0..(n - 1) / degree).map(|s| cp[s * degree..=s * degree + degree].to_vec()).collect()
            }
            "bspline" => {
                if n < degree + 1 {
                    return Err(format!(
                        "{n} control points: a degree {degree} B-spline takes at least {}",
                        degree + 1
                    ));
                }
                (0..n - degree).map(|s| bspline_to_bezier(&cp[s..=s + degree])).collect()
            }
            other => return Err(format!("unknown basis \"{other}\" (bezier or bspline)")),
        };
        let count = segments.len() as f64;
        let radii = |k: usize| 0.5 * scale * lerp(k as f64 / count, w0, w1);
        let segments: Vec<_> = segments.into_iter().enumerate().map(|(k, b)| (b, radii(k), radii(k + 1))).collect();
        append_strand(&mut self.strands, &segments)?;
        Ok(())
    }
}

/// Why a directive failed: its own problem (at its line), or an error in a file it includes.
enum Directive {
    Problem(String),
    Nested(PbrtError),
}

impl From<String> for Directive {
    fn from(p: String) -> Self {
        Directive::Problem(p)
    }
}

fn describe(t: &Token) -> String {
    match t {
        Token::Word(w) => format!("`{w}`"),
        Token::Str(s) => format!("\"{s}\""),
        Token::Number(x) => format!("the number {x}"),
        Token::Open => "`[`".into(),
        Token::Close => "`]`".into(),
    }
}

/// A directive's tokens as its plain values and its parameters.
fn arguments(tokens: Vec<Token>) -> Result<Args, String> {
    let mut it = tokens.into_iter().peekable();
    let mut values = Vec::new();
    // Plain values come first: a quoted string that is not "type name" (the shape's type), numbers.
    while let Some(t) = it.peek() {
        match t {
            Token::Str(s) if s.split_whitespace().count() == 2 => break,
            Token::Open => {
                it.next();
                for t in it.by_ref() {
                    match t {
                        Token::Close => break,
                        Token::Open => return Err("`[` inside `[`".into()),
                        t => values.push(t),
                    }
                }
            }
            Token::Close => return Err("`]` without `[`".into()),
            _ => values.push(it.next().expect("peeked")),
        }
    }
    let mut params = Vec::new();
    while let Some(t) = it.next() {
        let Token::Str(decl) = t else {
            return Err(format!("expected a \"type name\" parameter, found {}", describe(&t)));
        };
        let mut words = decl.split_whitespace();
        let (Some(kind), Some(name), None) = (words.next(), words.next(), words.next()) else {
            return Err(format!("\"{decl}\" is not a \"type name\" parameter"));
        };
        let values = match it.next() {
            Some(Token::Open) => {
                let mut v = Vec::new();
                loop {
                    match it.next() {
                        Some(Token::Close) => break,
                        Some(Token::Open) => return Err("`[` inside `[`".into()),
                        Some(t) => v.push(t),
                        None => return Err(format!("the values of \"{decl}\" are not closed by `]`")),
                    }
                }
                v
            }
            Some(Token::Close) => return Err("`]` without `[`".into()),
            Some(t) => vec![t],
            None => return Err(format!("\"{decl}\" has no value")),
        };
        params.push(Param { kind: kind.to_owned(), name: name.to_owned(), values });
    }
    Ok(Args { values, params })
}

/// The 4x4 matrix of `Transform`/`ConcatTransform` (pbrt lists it column by column).
fn matrix(args: &Args, name: &str) -> Result<DMat4, String> {
    let v = args.numbers(16, name)?;
    let m = DMat4::from_cols_slice(&v);
    if m.determinant() == 0.0 {
        return Err(format!("`{name}` with a singular matrix"));
    }
    Ok(m)
}
