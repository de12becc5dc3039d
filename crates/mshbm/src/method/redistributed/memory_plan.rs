//! The memory plan of the redistributed MS-HBM, checked by [`super::RedistributedMsHbm::new`]
//! and `set_sizes` before anything that grows with `H`, `N_s` or the interface is allocated
//! (the items every method shares are in [`crate::method::memory`]).

use crate::method::memory::{coefficients, mul, shared, Interface, MemoryPlan};
use crate::model::System;

/// The redistributed MS-HBM (paper Sections 3.1–3.2) with `H` harmonics and `N_s` samples,
/// in contact coordinates (docs/theory.md §16): unknowns `n_c (2H+1)`, four `n_c × n_c`
/// complex matrices per harmonic, the static contact problem and its cached active sets,
/// Gram blocks `(2H+1)²` per active set (at most one per contact plus one), per-sample
/// contact arrays. The exact receptance's sparse factors are counted with the linear
/// part; the modal receptance's mode shapes (`n × m` complex) are not, except for models
/// for which the default choice tries every mode
/// ([`super::EVERY_MODE_DOFS`], [`super::EVERY_MODE_MASS_PROPORTIONAL_DOFS`]): then the dense eigenproblem of every mode
/// ([`crate::modes::every_mode`]) and the shapes and damped shapes the receptance keeps.
pub fn memory_plan(system: &System, harmonics: usize, samples: usize) -> MemoryPlan {
    let mut plan = MemoryPlan::new();
    let nc = coefficients(harmonics);
    let n_n = system.nonlinear_dofs.len() as u64;
    let contacts = system.contacts.len() as u64;
    // contact coordinates (docs/theory.md §16): R_k, R_k⁻¹, D R_k⁻¹, Λ R_k⁻¹ per harmonic
    let interface = Interface {
        size: contacts,
        matrices: 4,
    };
    shared(
        &mut plan,
        system,
        harmonics,
        samples,
        contacts.checked_mul(nc),
        interface,
    );
    let massive = (system.n_dofs() - crate::modes::massless_dofs(&system.mass).len()) as u64;
    if super::takes_every_mode(system, massive as usize) {
        plan.add_product(
            format!("the modal receptance with every mode ({massive} modes)"),
            &[
                system.n_dofs() as u64,
                massive,
                8,
                crate::modes::EVERY_MODE_MATRICES,
            ],
        );
    }
    plan.add_product(
        "the scratch of the sparse solves of a block of columns",
        &[
            system.n_dofs() as u64,
            crate::linear::dynamic_stiffness::SPARSE_SOLVE_BLOCK as u64,
            16,
        ],
    );
    plan.add(
        "the static contact problem (K_NN⁻¹W, Delassus matrix)",
        mul(&[n_n.saturating_add(contacts), contacts, 8]),
    );
    // one n_c × n_c indicator per active set met, up to one per sample, within the cache
    plan.add(
        "the cached active sets of the static contact problem",
        mul(&[samples as u64, contacts, contacts, 8])
            .map(|b| b.min(crate::contact::static_contact::ACTIVE_SET_CACHE_BYTES as u64)),
    );
    plan.add(
        format!("the Gram blocks of the exact quadrature ({harmonics} harmonics)"),
        mul(&[contacts.saturating_add(1), nc, nc, 8]),
    );
    plan.add_product(
        format!("the contact arrays at {samples} samples"),
        &[samples as u64, n_n.saturating_add(contacts), 8, 4],
    );
    // 62 golden-section probes per max and per min of each contact and the response DOF,
    // each keeping its n_c forces (a Vec and a hash-table slot, doubled by rehashing)
    let probes = contacts
        .saturating_add(1)
        .saturating_mul(2 * 62)
        .min(super::MAX_CACHED_INSTANTS as u64);
    plan.add(
        "the contact forces kept by the extremum search".to_string(),
        mul(&[probes, contacts.saturating_mul(8).saturating_add(64), 2]),
    );
    // Coulomb friction (docs/theory.md §20): the coordinates above already hold the
    // tangents; the law keeps dλ̂/d[γ̂, a₀] of a march, its dλ̂/dγ̂ and the dense Jacobian
    // (three matrices of the unknowns' size squared), and each phase's anchor
    // sensitivities (taken as one phase per sample)
    // (one anchor per tangent: two per contact in the cone, (T218))
    let frictional = system
        .contacts
        .iter()
        .filter_map(|c| c.friction.as_ref())
        .map(|f| 1 + u64::from(f.second.is_some()))
        .sum::<u64>();
    if frictional > 0 {
        let unknowns = contacts.saturating_mul(nc);
        let columns = unknowns.saturating_add(frictional);
        plan.add_product(
            "the frictional law's derivatives and the dense Jacobian",
            &[unknowns, columns, 8, 3],
        );
        plan.add_product(
            format!("the anchor sensitivities of up to {samples} phases of friction"),
            &[samples as u64, frictional, columns, 8],
        );
        // the sets of modes kept between evaluations, emptied beyond their cap, and those
        // one march adds (taken as one per sample): F, G, Y_F, Y_G and the indicators
        let per_set = mul(&[contacts, contacts.saturating_add(frictional), 8, 3]);
        plan.add(
            "the friction law's sets of modes".to_string(),
            per_set
                .and_then(|p| p.checked_mul(samples as u64))
                .and_then(|p| p.checked_add(super::friction::MODE_CACHE_BYTES as u64)),
        );
    }
    plan
}
