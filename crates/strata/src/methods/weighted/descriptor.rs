//! The weighted methods' entries in the method table.

use crate::methods::table::{Descriptor, Family, MethodOption, Setup};
use crate::methods::{Method, MethodId};

fn create(id: MethodId, made: &Setup<'_>) -> crate::error::Result<Box<dyn Method>> {
    let Setup { gpu, scene, .. } = *made;
    Ok(if id == MethodId::Mboit {
        Box::new(super::mboit::Mboit::new(gpu, scene)?)
    } else {
        Box::new(super::Wboit::new(gpu, scene))
    })
}

/// `wboit`.
pub const WBOIT: Descriptor = Descriptor {
    memory: "(10·S + 4)·W·H; S samples per pixel (--msaa, else 1)",
    summary: "weighted blended OIT (McGuire & Bavoil 2013): weighted average color over exact coverage, weights of eqs. 7-10 (--weight, --depth-scale); what engines ship",
    reads: &[MethodOption::Weight],
    ..Descriptor::new(MethodId::Wboit, "wboit", Family::Weighted, create)
};

/// `mboit`.
pub const MBOIT: Descriptor = Descriptor {
    geometry_passes: "2",
    memory: "(28·S + 4)·W·H, +8·S with --moments 6, +16·S with 8; S samples per pixel (--msaa, else 1)",
    summary: "moment-based OIT (Münstermann et al. 2018): 4, 6 or 8 power moments of absorbance over log depth (--moments; 32-bit, bias 5e-7, 5e-7, 2e-6, overestimation 0.25), transmittance reconstructed per fragment; exact coverage",
    reads: &[MethodOption::Moments],
    ..Descriptor::new(MethodId::Mboit, "mboit", Family::Weighted, create)
};
