//! build.rs's half of the contract (the crate does not compile this file): `items.rs` expanded into
//! the text of "contract.cuh", the header every kernel includes. Each struct is written field for
//! field from its Rust definition, followed by `static_assert`s of the size and of every field's
//! offset as Rust lays the struct out; each constant becomes a `#define` with a literal of its type.

use std::fmt::Write as _;
use std::mem::{offset_of, size_of};

/// A Rust field type as C declares it.
trait CType {
    /// `float name`, `u32 name[3]`, `Material name`.
    fn declare(name: &str) -> String;
    /// Bytes of the scalar the type is made of, `None` for a struct: offsets are checked by pointer
    /// arithmetic on a scalar field before them (NVRTC has no offsetof).
    fn scalar_size() -> Option<usize>;
    fn is_array() -> bool {
        false
    }
}

macro_rules! scalar_types {
    ($($rust:ty => $c:literal),*) => {$(
        impl CType for $rust {
            fn declare(name: &str) -> String {
                format!("{} {name}", $c)
            }
            fn scalar_size() -> Option<usize> {
                Some(size_of::<$rust>())
            }
        }
    )*};
}
scalar_types!(f32 => "float", f64 => "double", u32 => "u32", u64 => "u64", i64 => "i64", i32 => "int");

impl<T: CType, const N: usize> CType for [T; N] {
    fn declare(name: &str) -> String {
        format!("{}[{N}]", T::declare(name))
    }
    fn scalar_size() -> Option<usize> {
        T::scalar_size()
    }
    fn is_array() -> bool {
        true
    }
}

/// A constant as a C literal of its type, so the kernels see the type they always saw.
trait CLiteral {
    fn literal(&self) -> String;
}

impl CLiteral for u32 {
    fn literal(&self) -> String {
        format!("{self}u")
    }
}

impl CLiteral for i32 {
    fn literal(&self) -> String {
        format!("{self}")
    }
}

impl CLiteral for f64 {
    fn literal(&self) -> String {
        format!("{self:?}")
    }
}

impl CLiteral for f32 {
    fn literal(&self) -> String {
        format!("{self:?}f")
    }
}

/// Defined only in build.rs's one compile of the header's field-offset checks.
pub const LAYOUT_CHECK: &str = "MPM_CONTRACT_LAYOUT_CHECK";

/// The source of that compile: the header with its offset checks, and no kernel.
pub fn layout_check_source() -> String {
    format!("#define {LAYOUT_CHECK}\n{}", contract_header())
}

struct Field {
    name: &'static str,
    declaration: String,
    docs: &'static [&'static str],
    offset: usize,
    scalar_size: Option<usize>,
    is_array: bool,
}

fn comment(out: &mut String, indent: &str, docs: &[&str]) {
    for line in docs {
        let _ = writeln!(out, "{indent}//{line}");
    }
}

fn write_struct(out: &mut String, name: &str, docs: &[&str], size: usize, fields: &[Field]) {
    comment(out, "", docs);
    let _ = writeln!(out, "struct {name} {{");
    for field in fields {
        comment(out, "    ", field.docs);
        let _ = writeln!(out, "    {};", field.declaration);
    }
    let _ = writeln!(out, "}};");
    let _ = writeln!(
        out,
        "static_assert(sizeof({name}) == {size}, \"{name} must be {size} bytes, as in src/contract/items.rs\");"
    );
    // Each field's offset, counted in the scalars of the nearest earlier field whose scalar size
    // divides the distance (a struct's first field sits at offset 0 in both languages).
    let probe = format!("{}_layout_probe", name.to_lowercase());
    let mut checks = String::new();
    for (i, field) in fields.iter().enumerate() {
        let base = fields[..i]
            .iter()
            .find(|b| b.scalar_size.is_some_and(|s| (field.offset - b.offset) % s == 0));
        let Some(base) = base else { continue };
        let word = if base.is_array {
            format!("{}[0]", base.name)
        } else {
            base.name.to_string()
        };
        let words = (field.offset - base.offset) / base.scalar_size.unwrap_or(1);
        let _ = writeln!(
            checks,
            "static_assert((const void*)&{probe}.{field} == (const void*)(&{probe}.{word} + {words}), \
             \"{name}::{field} must sit at byte {offset}, as in src/contract/items.rs\");",
            field = field.name,
            offset = field.offset,
        );
    }
    // A probe object for the checks would be emitted into every module's PTX, so they are compiled
    // once, by build.rs's layout check (`LAYOUT_CHECK`), not into the kernels.
    if !checks.is_empty() {
        let _ = writeln!(out, "#ifdef {LAYOUT_CHECK}");
        let _ = writeln!(out, "__device__ constexpr {name} {probe}{{}};");
        out.push_str(&checks);
        let _ = writeln!(out, "#endif");
    }
    out.push('\n');
}

macro_rules! device_structs {
    ($(
        $(#[doc = $doc:literal])*
        struct $name:ident {
            $( $(#[doc = $field_doc:literal])* $field:ident : $ty:ty ),* $(,)?
        }
    )*) => {
        $(
            #[allow(dead_code)]
            #[repr(C)]
            struct $name {
                $( $field: $ty, )*
            }

            impl CType for $name {
                fn declare(name: &str) -> String {
                    format!("{} {name}", stringify!($name))
                }
                fn scalar_size() -> Option<usize> {
                    None
                }
            }
        )*

        fn write_structs(out: &mut String) {
            $(
                let fields = [$(
                    Field {
                        name: stringify!($field),
                        declaration: <$ty as CType>::declare(stringify!($field)),
                        docs: &[$($field_doc),*],
                        offset: offset_of!($name, $field),
                        scalar_size: <$ty as CType>::scalar_size(),
                        is_array: <$ty as CType>::is_array(),
                    },
                )*];
                write_struct(out, stringify!($name), &[$($doc),*], size_of::<$name>(), &fields);
            )*
        }
    };
}

macro_rules! device_constants {
    ($( $(#[doc = $doc:literal])* $name:ident : $ty:ty = $value:expr; )*) => {
        fn write_constants(out: &mut String) {
            $(
                comment(out, "", &[$($doc),*]);
                let value: $ty = $value;
                let _ = writeln!(out, "#define {} {}", stringify!($name), value.literal());
            )*
        }
    };
}

include!("items.rs");

/// The text of "contract.cuh".
pub fn contract_header() -> String {
    let mut out = String::from(
        "// contract.cuh: written by build.rs from src/contract/items.rs (edit that file, not this text).\n\
         // The structs the kernels share with the host and the constants both sides name.\n\n\
         typedef unsigned int u32;\n\
         typedef unsigned long long u64;\n\
         typedef long long i64;\n\n",
    );
    write_constants(&mut out);
    out.push('\n');
    write_structs(&mut out);
    out
}
