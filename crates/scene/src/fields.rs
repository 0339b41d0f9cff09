//! Typed, line-aware access to the keys of one TOML table.
//!
//! Every value read from a scene file goes through here so that each refusal
//! carries the file, the 1-based line of the offending key and the key's name,
//! and so that no value is taken without its type, length and finiteness
//! being checked.

use super::SceneError;
use glam::Vec3;
use std::path::{Path, PathBuf};
use toml::de::{DeTable, DeValue};

/// Largest magnitude accepted for any number in a scene. Far beyond any
/// sensible scene, but small enough that products of a few coordinates
/// (areas, cross products, normals) can never overflow f32.
pub const MAX_MAGNITUDE: f64 = 1e8;

/// The file being parsed: its name for messages, its directory for relative
/// paths, and where each line starts so byte spans become line numbers.
pub struct Ctx {
    pub file: PathBuf,
    pub base_dir: PathBuf,
    line_starts: Vec<usize>,
}

impl Ctx {
    pub fn new(text: &str, file: &Path) -> Ctx {
        let mut line_starts = vec![0];
        line_starts.extend(text.match_indices('\n').map(|(i, _)| i + 1));
        Ctx {
            file: file.to_path_buf(),
            base_dir: file.parent().map(Path::to_path_buf).unwrap_or_default(),
            line_starts,
        }
    }

    /// 1-based line holding byte offset `byte`.
    pub fn line_of(&self, byte: usize) -> usize {
        self.line_starts.partition_point(|&s| s <= byte).max(1)
    }

    pub fn error(&self, line: usize, message: impl Into<String>) -> SceneError {
        SceneError {
            file: self.file.clone(),
            line,
            message: message.into(),
        }
    }

    /// A path from the file, resolved against the file's directory.
    pub fn resolve(&self, rel: &str) -> PathBuf {
        self.base_dir.join(rel)
    }
}

/// One key as found in the file.
pub struct Field<'a, 'i> {
    pub key: &'a str,
    pub line: usize,
    pub value: &'a DeValue<'i>,
}

/// A table of the scene (`[camera]`, one `[[material]]`, ...) with the label
/// that prefixes its messages (`material "floor"`, `object 3 (box)`).
pub struct Section<'a, 'i> {
    pub ctx: &'a Ctx,
    pub label: String,
    /// Line of the table's header (or of its key, for inline tables); used
    /// for keys that are missing.
    pub line: usize,
    table: &'a DeTable<'i>,
}

pub type Result<T> = std::result::Result<T, SceneError>;

/// Entries of a table in file order (the parser's map is sorted by name), so
/// that the first problem reported is the first one in the file.
pub fn entries_in_order<'a, 'i>(ctx: &Ctx, table: &'a DeTable<'i>) -> Vec<Field<'a, 'i>> {
    let mut v: Vec<(usize, Field<'a, 'i>)> = table
        .iter()
        .map(|(k, v)| {
            let start = k.span().start;
            (
                start,
                Field {
                    key: k.get_ref().as_ref(),
                    line: ctx.line_of(start),
                    value: v.get_ref(),
                },
            )
        })
        .collect();
    v.sort_by_key(|(s, _)| *s);
    v.into_iter().map(|(_, f)| f).collect()
}

fn number(value: &DeValue<'_>) -> Option<f64> {
    match value {
        DeValue::Float(f) => f.as_str().replace('_', "").parse::<f64>().ok(),
        DeValue::Integer(i) => i64::from_str_radix(&i.as_str().replace('_', ""), i.radix())
            .ok()
            .map(|x| x as f64),
        _ => None,
    }
}

/// Short form of a number for messages (`1.7`, `NaN`, `inf`). Values are
/// printed at the precision they are stored in (f32 for scene values, f64 for
/// raw file values) so `1.7` reads back as `1.7`.
pub fn fmt_num(x: impl std::fmt::Display) -> String {
    format!("{x}")
}

pub fn fmt_vec(v: &[f64]) -> String {
    let parts: Vec<String> = v.iter().map(|x| fmt_num(*x)).collect();
    format!("[{}]", parts.join(", "))
}

pub fn fmt_vec3(v: Vec3) -> String {
    format!("[{}, {}, {}]", v.x, v.y, v.z)
}

fn in_range(x: f64) -> bool {
    x.is_finite() && x.abs() <= MAX_MAGNITUDE && (x as f32).is_finite()
}

impl<'a, 'i> Section<'a, 'i> {
    pub fn new(ctx: &'a Ctx, label: String, line: usize, table: &'a DeTable<'i>) -> Self {
        Section {
            ctx,
            label,
            line,
            table,
        }
    }

    /// An error prefixed with this section's label.
    pub fn err(&self, line: usize, message: impl std::fmt::Display) -> SceneError {
        self.ctx.error(line, format!("{}: {}", self.label, message))
    }

    /// Refuses the first key (in file order) not in `allowed`.
    pub fn allow_only(&self, allowed: &[&str]) -> Result<()> {
        for f in entries_in_order(self.ctx, self.table) {
            if !allowed.contains(&f.key) {
                return Err(self.err(
                    f.line,
                    format!(
                        "unknown key `{}` (allowed here: {})",
                        f.key,
                        allowed.join(", ")
                    ),
                ));
            }
        }
        Ok(())
    }

    pub fn field(&self, key: &str) -> Option<Field<'a, 'i>> {
        self.table.iter().find_map(|(k, v)| {
            (k.get_ref().as_ref() == key).then(|| Field {
                key: k.get_ref().as_ref(),
                line: self.ctx.line_of(k.span().start),
                value: v.get_ref(),
            })
        })
    }

    pub fn require(&self, key: &str) -> Result<Field<'a, 'i>> {
        self.field(key)
            .ok_or_else(|| self.err(self.line, format!("missing required key `{key}`")))
    }

    /// A number (integer or float), finite and within ±MAX_MAGNITUDE.
    pub fn number_of(&self, f: &Field<'_, '_>) -> Result<f32> {
        let x = number(f.value).ok_or_else(|| {
            self.err(
                f.line,
                format!("{} must be a number, found {}", f.key, f.value.type_str()),
            )
        })?;
        if !in_range(x) {
            return Err(self.err(
                f.line,
                format!(
                    "{} = {} is not a finite number within ±{:e}",
                    f.key,
                    fmt_num(x),
                    MAX_MAGNITUDE
                ),
            ));
        }
        Ok(x as f32)
    }

    pub fn number(&self, key: &str) -> Result<(f32, usize)> {
        let f = self.require(key)?;
        Ok((self.number_of(&f)?, f.line))
    }

    pub fn opt_number(&self, key: &str) -> Result<Option<(f32, usize)>> {
        self.field(key)
            .map(|f| Ok((self.number_of(&f)?, f.line)))
            .transpose()
    }

    /// An array of `n` numbers, each finite and within ±MAX_MAGNITUDE.
    pub fn numbers_of(&self, f: &Field<'_, '_>, n: usize) -> Result<Vec<f32>> {
        let DeValue::Array(items) = f.value else {
            return Err(self.err(
                f.line,
                format!(
                    "{} must be an array of {n} numbers, found {}",
                    f.key,
                    f.value.type_str()
                ),
            ));
        };
        if items.len() != n {
            return Err(self.err(
                f.line,
                format!("{} must have {n} components, found {}", f.key, items.len()),
            ));
        }
        let mut raw = Vec::with_capacity(n);
        for (i, item) in items.iter().enumerate() {
            let x = number(item.get_ref()).ok_or_else(|| {
                self.err(
                    f.line,
                    format!(
                        "{}[{i}] must be a number, found {}",
                        f.key,
                        item.get_ref().type_str()
                    ),
                )
            })?;
            raw.push(x);
        }
        if let Some(i) = raw.iter().position(|x| !in_range(*x)) {
            return Err(self.err(
                f.line,
                format!(
                    "{} = {}: component {i} is not a finite number within ±{:e}",
                    f.key,
                    fmt_vec(&raw),
                    MAX_MAGNITUDE
                ),
            ));
        }
        Ok(raw.into_iter().map(|x| x as f32).collect())
    }

    pub fn vec3_of(&self, f: &Field<'_, '_>) -> Result<Vec3> {
        let v = self.numbers_of(f, 3)?;
        Ok(Vec3::new(v[0], v[1], v[2]))
    }

    pub fn vec3(&self, key: &str) -> Result<(Vec3, usize)> {
        let f = self.require(key)?;
        Ok((self.vec3_of(&f)?, f.line))
    }

    pub fn opt_vec3(&self, key: &str) -> Result<Option<(Vec3, usize)>> {
        self.field(key)
            .map(|f| Ok((self.vec3_of(&f)?, f.line)))
            .transpose()
    }

    /// A colour: three numbers, each in [0, 1].
    pub fn unit_rgb(&self, key: &str) -> Result<(Vec3, usize)> {
        let (v, line) = self.vec3(key)?;
        if v.to_array().iter().any(|c| !(0.0..=1.0).contains(c)) {
            return Err(self.err(
                line,
                format!("{key} = {} has a channel outside [0, 1]", fmt_vec3(v)),
            ));
        }
        Ok((v, line))
    }

    pub fn string(&self, key: &str) -> Result<(&'a str, usize)> {
        let f = self.require(key)?;
        Ok((self.string_of(&f)?, f.line))
    }

    pub fn string_of(&self, f: &Field<'a, '_>) -> Result<&'a str> {
        match f.value {
            DeValue::String(s) => Ok(s.as_ref()),
            other => Err(self.err(
                f.line,
                format!("{} must be a string, found {}", f.key, other.type_str()),
            )),
        }
    }

    pub fn opt_string(&self, key: &str) -> Result<Option<(&'a str, usize)>> {
        self.field(key)
            .map(|f| Ok((self.string_of(&f)?, f.line)))
            .transpose()
    }

    pub fn opt_bool(&self, key: &str) -> Result<Option<(bool, usize)>> {
        self.field(key)
            .map(|f| match f.value {
                DeValue::Boolean(b) => Ok((*b, f.line)),
                other => Err(self.err(
                    f.line,
                    format!(
                        "{} must be true or false, found {}",
                        f.key,
                        other.type_str()
                    ),
                )),
            })
            .transpose()
    }

    /// An integer in `lo..=hi` (a float, even 3.0, is refused: counts are
    /// whole numbers and a fraction is a mistake).
    pub fn opt_int(&self, key: &str, lo: i64, hi: i64) -> Result<Option<(i64, usize)>> {
        let Some(f) = self.field(key) else {
            return Ok(None);
        };
        let DeValue::Integer(i) = f.value else {
            return Err(self.err(
                f.line,
                format!("{key} must be an integer, found {}", f.value.type_str()),
            ));
        };
        let text = i.as_str().replace('_', "");
        let x = i64::from_str_radix(&text, i.radix())
            .map_err(|_| self.err(f.line, format!("{key} = {text} is outside [{lo}, {hi}]")))?;
        if !(lo..=hi).contains(&x) {
            return Err(self.err(f.line, format!("{key} = {x} is outside [{lo}, {hi}]")));
        }
        Ok(Some((x, f.line)))
    }

    /// The elements of an array key, each with the key's line (messages point
    /// at the key, as for every other value).
    pub fn array_of(&self, f: &Field<'a, 'i>) -> Result<Vec<&'a DeValue<'i>>> {
        match f.value {
            DeValue::Array(items) => Ok(items.iter().map(|s| s.get_ref()).collect()),
            other => Err(self.err(
                f.line,
                format!("{} must be an array, found {}", f.key, other.type_str()),
            )),
        }
    }

    /// A vec3 given as a bare array value (e.g. one vertex of a polygon),
    /// reported as `key[index]`.
    pub fn vec3_elem(&self, f: &Field<'_, '_>, index: usize, value: &DeValue<'_>) -> Result<Vec3> {
        let name = format!("{}[{index}]", f.key);
        let elem = Field {
            key: &name,
            line: f.line,
            value,
        };
        self.vec3_of(&elem)
    }
}
