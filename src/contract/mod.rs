//! The host/device contract: every struct the kernels share with the host and every constant both
//! sides name, written once in `items.rs`. This module expands them into Rust items (`#[repr(C)]`,
//! Pod, passable to a kernel); build.rs expands the same file into the header the kernels include
//! (`#include "contract.cuh"`), with `static_assert`s of each struct's size and field offsets as Rust
//! lays them out. So the two sides cannot drift apart: there is no second copy to forget.

macro_rules! device_structs {
    ($(
        $(#[doc = $doc:literal])*
        struct $name:ident {
            $( $(#[doc = $field_doc:literal])* $field:ident : $ty:ty ),* $(,)?
        }
    )*) => {$(
        $(#[doc = $doc])*
        #[repr(C)]
        #[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
        pub struct $name {
            $( $(#[doc = $field_doc])* pub $field: $ty, )*
        }

        // SAFETY: `#[repr(C)]` and Pod (no padding, every bit pattern valid), and the kernels' struct is
        // written from this definition by build.rs, which checks its size and offsets there.
        unsafe impl cudarc::driver::DeviceRepr for $name {}
        // SAFETY: Zeroable: all-zero bits are a valid value.
        unsafe impl cudarc::driver::ValidAsZeroBits for $name {}
    )*};
}

macro_rules! device_constants {
    ($( $(#[doc = $doc:literal])* $name:ident : $ty:ty = $value:expr; )*) => {$(
        $(#[doc = $doc])*
        pub const $name: $ty = $value;
    )*};
}

include!("items.rs");
