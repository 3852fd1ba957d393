//! GPU structs declared once. A struct that Rust writes into a buffer and WGSL reads is declared
//! in Rust with `gpu_struct!`, which also makes its WGSL declaration (at compile time, doc
//! comments included); the shaders import that declaration from a module made by
//! `wgsl_module!` instead of repeating the fields, so the two sides cannot drift apart. Fields
//! are scalars, vectors (`[f32; N]` → `vecN<f32>`) and matrices, in WGSL's order with WGSL's
//! alignment spelled out as explicit padding fields; `assert_twin` (run for every such struct)
//! checks that naga lays the WGSL out at Rust's offsets and size and accepts it as a uniform.

/// A Rust field type of a `gpu_struct!` and the WGSL type it is declared as.
pub trait WgslType: bytemuck::Pod {
    /// The WGSL type.
    const WGSL: &'static str;
}

macro_rules! wgsl_types {
    ($($rust:ty => $wgsl:literal),* $(,)?) => {$(
        impl WgslType for $rust {
            const WGSL: &'static str = $wgsl;
        }
    )*};
}

wgsl_types! {
    u32 => "u32",
    i32 => "i32",
    f32 => "f32",
    [u32; 2] => "vec2<u32>",
    [u32; 3] => "vec3<u32>",
    [u32; 4] => "vec4<u32>",
    [f32; 2] => "vec2<f32>",
    [f32; 3] => "vec3<f32>",
    [f32; 4] => "vec4<f32>",
    [[f32; 4]; 4] => "mat4x4<f32>",
}

/// A struct declared by `gpu_struct!`.
pub trait GpuStruct: bytemuck::Pod {
    /// Its WGSL declaration.
    const WGSL: &'static str;
    /// Its fields' names and byte offsets, in order.
    fn offsets() -> Vec<(&'static str, usize)>;
}

/// Declares a `#[repr(C)]` plain-data struct that shaders read, and its WGSL declaration
/// ([`GpuStruct::WGSL`]): the same name, the same fields in the same order, each field's doc
/// comment as a WGSL comment. Every field is of a [`WgslType`]; padding fields are private
/// (`pad_a: u32`) and set with `..Zeroable::zeroed()` where the struct is made elsewhere.
macro_rules! gpu_struct {
    (
        $(#[$attr:meta])*
        $struct_vis:vis struct $name:ident {
            $(
                $(#[doc = $field_doc:literal])*
                $vis:vis $field:ident: $ty:ty,
            )*
        }
    ) => {
        $(#[$attr])*
        #[repr(C)]
        #[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
        $struct_vis struct $name {
            $(
                $(#[doc = $field_doc])*
                $vis $field: $ty,
            )*
        }

        impl $crate::gpu::twin::GpuStruct for $name {
            const WGSL: &'static str = const_format::concatcp!(
                "struct ",
                stringify!($name),
                " {\n",
                $(
                    $("    //", $field_doc, "\n",)*
                    "    ",
                    stringify!($field),
                    ": ",
                    <$ty as $crate::gpu::twin::WgslType>::WGSL,
                    ",\n",
                )*
                "}\n"
            );

            fn offsets() -> Vec<(&'static str, usize)> {
                vec![$((stringify!($field), std::mem::offset_of!($name, $field))),*]
            }
        }
    };
}
pub(crate) use gpu_struct;

/// A WGSL module (a naga_oil library source) named `path` that declares the [`gpu_struct!`]s
/// given, for the shaders to `#import`.
macro_rules! wgsl_module {
    ($path:literal, $($struct:ty),+ $(,)?) => {
        const_format::concatcp!(
            "#define_import_path ",
            $path,
            "\n\n",
            $(<$struct as $crate::gpu::twin::GpuStruct>::WGSL, "\n",)+
        )
    };
}
pub(crate) use wgsl_module;

/// A WGSL module named `path` of `u32` constants made from Rust constant expressions
/// (`NAME = expr`, each converted with `as u32`, which fails to compile where a value does not
/// fit), so that a number both sides use is written once, in Rust.
macro_rules! wgsl_constants {
    ($path:literal, $($name:ident = $value:expr),+ $(,)?) => {{
        $(const _: () = assert!(($value) as u64 <= u32::MAX as u64, stringify!($name));)+
        const_format::concatcp!(
            "#define_import_path ",
            $path,
            "\n\n",
            $("const ", stringify!($name), ": u32 = ", ($value) as u32, "u;\n",)+
        )
    }};
}
pub(crate) use wgsl_constants;

/// Checks `T`'s WGSL declaration: naga parses it, accepts it as a uniform, and lays it out at
/// Rust's size and field offsets.
#[cfg(test)]
pub fn assert_twin<T: GpuStruct>() {
    let name = std::any::type_name::<T>().rsplit("::").next().unwrap();
    let source = format!(
        "{}\n@group(0) @binding(0) var<uniform> twin: {name};\n",
        T::WGSL
    );
    let module = crate::gpu::shader::validate_wgsl(name, &source);
    let mut layouter = naga::proc::Layouter::default();
    layouter.update(module.to_ctx()).unwrap();
    let (handle, ty) = module
        .types
        .iter()
        .find(|(_, t)| t.name.as_deref() == Some(name))
        .unwrap_or_else(|| panic!("{name}: not declared in\n{source}"));
    let naga::TypeInner::Struct { members, span } = &ty.inner else {
        panic!("{name}: not a struct");
    };
    let wgsl: Vec<_> = members
        .iter()
        .map(|m| (m.name.as_deref().unwrap_or(""), m.offset as usize))
        .collect();
    assert_eq!(wgsl, T::offsets(), "{name}: WGSL offsets against Rust's");
    assert_eq!(
        *span as usize,
        std::mem::size_of::<T>(),
        "{name}: WGSL size against Rust's"
    );
    assert_eq!(layouter[handle].size, *span);
}

#[cfg(test)]
mod tests {
    use super::*;

    gpu_struct! {
        /// A test struct.
        pub struct Probe {
            /// Where.
            pub position: [f32; 3],
            pub count: u32,
            pad_a: u32,
            pad_b: u32,
            pad_c: u32,
            pad_d: u32,
        }
    }

    #[test]
    fn the_wgsl_declaration_is_made_from_the_rust_one() {
        assert_eq!(
            Probe::WGSL,
            "struct Probe {\n    // Where.\n    position: vec3<f32>,\n    count: u32,\n    \
             pad_a: u32,\n    pad_b: u32,\n    pad_c: u32,\n    pad_d: u32,\n}\n"
        );
        assert_twin::<Probe>();
        let module = wgsl_module!("strata::probe", Probe);
        assert!(module.starts_with("#define_import_path strata::probe\n\nstruct Probe {"));
        const WORDS: u64 = 12;
        assert_eq!(
            wgsl_constants!("strata::probe_constants", WORDS = WORDS / 4, FLAG = 1usize << 3),
            "#define_import_path strata::probe_constants\n\nconst WORDS: u32 = 3u;\nconst FLAG: u32 = 8u;\n"
        );
    }

    gpu_struct! {
        /// Three scalars fill the space before the vector: the same layout on both sides.
        pub struct Packed {
            pub a: f32,
            pub b: f32,
            pub c: f32,
            pub count: u32,
            pub v: [f32; 4],
        }
    }

    gpu_struct! {
        /// Rust puts `v` at 4, WGSL at 16.
        pub struct Unpadded {
            pub count: u32,
            pub v: [f32; 3],
        }
    }

    #[test]
    fn a_layout_that_differs_fails_the_check() {
        assert_twin::<Packed>();
        let caught = std::panic::catch_unwind(assert_twin::<Unpadded>);
        assert!(caught.is_err(), "a vec3 at offset 4 should not pass");
    }
}
