//! The partition invariant, property-tested: in every frame the components' OWN sets
//! are disjoint and their union is the whole frame.

use objectsplat_core::component::{OTHER, OWN};
use objectsplat_core::masks::UNOWNED;
use objectsplat_core::{IdMap, ObjectLabels};
use objectsplat_masks::partition::Owner;
use objectsplat_masks::{PartitionParams, plan_partition};
use proptest::prelude::*;

/// Random id maps over a few object ids (some unlabelled-free: every id used has a
/// label), with 0 and UNOWNED mixed in.
fn frames_strategy() -> impl Strategy<Value = (Vec<IdMap>, ObjectLabels)> {
    (1u32..6, 1u32..6, 1usize..5, 1u16..6).prop_flat_map(|(w, h, n, objects)| {
        let values = prop_oneof![Just(0u16), Just(UNOWNED), 1..=objects];
        (
            prop::collection::vec(prop::collection::vec(values, (w * h) as usize), n),
            Just((w, h, objects)),
        )
            .prop_map(|(data, (w, h, objects))| {
                let maps = data
                    .into_iter()
                    .map(|d| IdMap {
                        width: w,
                        height: h,
                        data: d,
                    })
                    .collect();
                let labels = (1..=objects).map(|id| (id, format!("thing{id}"))).collect();
                (maps, labels)
            })
    })
}

proptest! {
    #[test]
    fn components_partition_every_frame((maps, labels) in frames_strategy(), budget in 0u64..12, holistic: bool) {
        let plan = plan_partition(&maps, &labels, &PartitionParams { min_pixels: Some(budget), holistic }).unwrap();
        for (f, map) in maps.iter().enumerate() {
            let mut owners = vec![0u32; map.data.len()];
            for c in &plan.components {
                let mask = plan.component_mask(c, map);
                prop_assert!(mask.iter().all(|&v| v == OWN || v == OTHER));
                let owns_here = mask.contains(&OWN);
                // A component that owns a pixel of a frame must include that frame.
                prop_assert!(!owns_here || c.frames.contains(&f), "{} owns pixels of frame {f} it does not list", c.info.name);
                for (o, &v) in owners.iter_mut().zip(&mask) {
                    *o += u32::from(v == OWN);
                }
            }
            prop_assert!(owners.iter().all(|&n| n == 1), "frame {f}: ownership counts {owners:?}");
        }
        // Objects are kept exactly when they reach the budget; the pixel totals add up.
        let total: u64 = maps.iter().map(|m| m.data.len() as u64).sum();
        prop_assert_eq!(plan.components.iter().map(|c| c.pixels).sum::<u64>(), total);
        for c in &plan.components {
            if let Owner::Object(id) = c.owner {
                let n = maps.iter().flat_map(|m| &m.data).filter(|&&v| v == id).count() as u64;
                prop_assert_eq!(n, c.pixels);
                prop_assert!(n >= budget && n > 0);
            }
        }
        for d in &plan.dropped {
            prop_assert!(d.pixels < budget || d.pixels == 0);
        }
        if holistic {
            prop_assert_eq!(plan.components.len(), 1);
            prop_assert_eq!(plan.components[0].info.name.as_str(), "scene");
        } else {
            prop_assert_eq!(plan.components.last().map(|c| c.owner), Some(Owner::Background));
        }
    }
}
