use super::*;
use crate::mesh_checks;
use crate::phantom::{self, Family, PhantomOptions, Shape};

fn one(label: u32, seed: DVec3) -> ObjectSeeds {
    ObjectSeeds {
        label,
        seeds: vec![seed],
    }
}

fn obstacle_of(mesh: &TriMesh, reach: f64) -> Arc<Obstacle> {
    Arc::new(Obstacle::of_mesh(mesh, reach))
}

/// `variant` with its seed as object 1 and its other object's deepest point as object 2.
fn both_seeded(variant: &phantom::Variant) -> Vec<SegmentedObject> {
    let request = ObjectsRequest {
        objects: vec![
            one(1, variant.seed()),
            one(2, variant.other_seed().unwrap()),
        ],
        ..ObjectsRequest::default()
    };
    segment_objects(
        variant.image.view(),
        BalloonParams::default(),
        &request,
        None,
    )
    .unwrap()
}

#[test]
fn two_touching_tubes_come_out_valid_apart_and_each_around_its_seed() {
    for number in [1, 6, 7] {
        let variant = Family::TouchingPair.variant(number).unwrap();
        let objects = both_seeded(&variant);
        assert_eq!(objects.iter().map(|o| o.label).collect::<Vec<_>>(), [1, 2]);
        let reach = 3.0 * variant.image.geometry().max_spacing();
        for (object, other) in [(&objects[0], &objects[1]), (&objects[1], &objects[0])] {
            let report = mesh_checks::check(&object.mesh);
            assert!(report.is_valid_closed_surface(), "{number}: {report:?}");
            assert!(crate::self_intersection::self_intersections(&object.mesh)
                .unwrap()
                .is_empty());
            let others = [obstacle_of(&other.mesh, reach)];
            assert_eq!(crossings(&object.mesh, &others).unwrap(), [] as [u32; 0]);
            // Each holds its own seed and not the other's.
            let own = obstacle_of(&object.mesh, 1e3);
            let depth = |p: DVec3| own.signed_distance(p).unwrap();
            assert!(depth(object.seeds[0]) < 0.0, "{number}");
            assert!(depth(other.seeds[0]) > 0.0, "{number}");
        }
    }
}

#[test]
fn a_tube_one_object_cut_off_or_left_is_grown_into_by_the_other() {
    // Variant 7: the thicker balloon took the slanted tube's far half through their contact and
    // cut it off after the repartition, when the other had stopped at it: Dice 0.48. Variant 6:
    // the same after the first object's final cut, with the second finished in lockstep: 0.56.
    for number in [6, 7] {
        let variant = Family::TouchingPair.variant(number).unwrap();
        let objects = both_seeded(&variant);
        let step = 0.25 * variant.image.geometry().min_spacing();
        let second = crate::evaluation::overlap_with_shape(
            &objects[1].mesh,
            variant.other().unwrap(),
            variant.other_bounds().unwrap(),
            step,
        )
        .unwrap();
        assert!(second.dice() > 0.9, "{number}: {}", second.dice());
    }
}

#[test]
fn a_second_object_crossing_the_first_where_it_was_faired_keeps_the_gap_near_the_clearance() {
    // The first object's final fairing moved it into the second, whose re-parametrised surface
    // then crossed it until its clearance was widened everywhere: widest gaps 1.56 and 1.55
    // voxels. Moved out where they cross, 1.34 and 1.29.
    for number in [1, 5] {
        let variant = Family::TouchingPair.variant(number).unwrap();
        let objects = both_seeded(&variant);
        let voxel = variant.image.geometry().max_spacing();
        let [a, b] = [&objects[0].mesh, &objects[1].mesh];
        let gap =
            crate::evaluation::widest_gap_at_contact(a, variant.other().unwrap(), b, 0.5 * voxel)
                .unwrap()
                .max(
                    crate::evaluation::widest_gap_at_contact(
                        b,
                        |p| variant.truth(p),
                        a,
                        0.5 * voxel,
                    )
                    .unwrap(),
                );
        assert!(gap <= 1.4 * voxel, "{number}: {} voxels", gap / voxel);
    }
}

#[test]
fn one_object_is_the_segmenter_alone() {
    let p = phantom::render(Shape::TouchingTubes, &PhantomOptions::default()).unwrap();
    let request = ObjectsRequest {
        objects: vec![one(7, p.seed_world())],
        ..ObjectsRequest::default()
    };
    let objects =
        segment_objects(p.image.view(), BalloonParams::default(), &request, None).unwrap();
    let alone = Segmenter::new(p.image.view(), BalloonParams::default(), p.seed_world())
        .unwrap()
        .segment()
        .unwrap();
    assert_eq!(objects.len(), 1);
    assert_eq!(objects[0].label, 7);
    assert_eq!((objects[0].mesh.clone(), objects[0].states.clone()), alone);
}

#[test]
fn a_stop_seed_keeps_the_object_out_and_is_not_returned() {
    let variant = Family::TouchingPair.variant(6).unwrap();
    let request = ObjectsRequest {
        objects: vec![one(3, variant.seed())],
        stops: vec![variant.other_seed().unwrap()],
        region: None,
    };
    let objects = segment_objects(
        variant.image.view(),
        BalloonParams::default(),
        &request,
        None,
    )
    .unwrap();
    assert_eq!(objects.len(), 1);
    assert_eq!(objects[0].label, 3);
    let own = obstacle_of(&objects[0].mesh, 1e3);
    assert!(own.signed_distance(request.stops[0]).unwrap() > 0.0);
}

#[test]
fn the_region_of_interest_bounds_the_balloon() {
    let p = phantom::render(Shape::Sphere, &PhantomOptions::default()).unwrap();
    let seed = p.seed_world();
    // The sphere's radius is 10 mm: the box cuts it 4 mm above the seed.
    let region = Region::new(
        seed - DVec3::splat(20.0),
        seed + DVec3::new(20.0, 20.0, 4.0),
    )
    .unwrap();
    let request = ObjectsRequest {
        objects: vec![one(1, seed)],
        stops: Vec::new(),
        region: Some(region),
    };
    let objects =
        segment_objects(p.image.view(), BalloonParams::default(), &request, None).unwrap();
    let mesh = &objects[0].mesh;
    assert!(mesh_checks::check(mesh).is_valid_closed_surface());
    let (lo, hi) = mesh.bounds().unwrap();
    let voxel = p.image.geometry().max_spacing();
    assert!(hi.z <= seed.z + 4.0 + 0.5 * voxel, "{hi}");
    assert!(
        hi.z >= seed.z + 4.0 - voxel,
        "{hi}: short of the region's face"
    );
    assert!(lo.z < seed.z - 9.0, "{lo}");
}

#[test]
fn bad_requests_name_the_seed_and_what_to_change() {
    let p = phantom::render(Shape::TouchingTubes, &PhantomOptions::default()).unwrap();
    let seed = p.seed_world();
    let voxel = p.image.geometry().min_spacing();
    let run = |request: ObjectsRequest| {
        segment_objects(p.image.view(), BalloonParams::default(), &request, None)
            .unwrap_err()
            .to_string()
    };
    let label_zero = run(ObjectsRequest {
        objects: vec![one(0, seed)],
        ..ObjectsRequest::default()
    });
    assert!(
        label_zero.contains("label 0") && label_zero.contains("1 to"),
        "{label_zero}"
    );
    let too_large = run(ObjectsRequest {
        objects: vec![one(MAX_LABEL + 1, seed)],
        ..ObjectsRequest::default()
    });
    assert!(too_large.contains("labels are 1 to"), "{too_large}");
    let shared = run(ObjectsRequest {
        objects: vec![one(1, seed), one(2, seed + DVec3::splat(0.1 * voxel))],
        ..ObjectsRequest::default()
    });
    assert!(
        shared.contains("object 2") && shared.contains("object 1") && shared.contains("voxel"),
        "{shared}"
    );
    let stopped = run(ObjectsRequest {
        objects: vec![one(1, seed)],
        stops: vec![seed],
        region: None,
    });
    assert!(
        stopped.contains("stop seed") && stopped.contains("object 1"),
        "{stopped}"
    );
    let many = run(ObjectsRequest {
        objects: (1..=MAX_OBJECTS as u32 + 1)
            .map(|l| one(l, seed + DVec3::X * l as f64 * 100.0 * voxel))
            .collect(),
        ..ObjectsRequest::default()
    });
    assert!(many.contains("at most"), "{many}");
    let none = run(ObjectsRequest::default());
    assert!(none.contains("at least one seed"), "{none}");
    let outside = run(ObjectsRequest {
        objects: vec![one(1, seed)],
        stops: Vec::new(),
        region: Some(Region::new(seed + DVec3::ONE, seed + DVec3::splat(5.0)).unwrap()),
    });
    assert!(outside.contains("outside the region"), "{outside}");
}

/// How far (mm, along the opening's normal, towards the vessel) the vessel object's nearest
/// point to the chamber lies from the opening's plane of vessel-chamber `variant`.
fn end_beyond_opening(variant: &phantom::Variant, vessel: &TriMesh) -> f64 {
    let parameter = |name: &str| {
        let found = variant.describe().iter().find(|p| p.name == name).unwrap();
        DVec3::from_slice(&found.values)
    };
    let (centre, normal) = (parameter("opening_centre"), parameter("opening_normal"));
    vessel
        .points()
        .iter()
        .map(|&p| (p - centre).dot(normal))
        .fold(f64::INFINITY, f64::min)
}

#[test]
fn a_vessel_seeded_beside_its_chamber_ends_at_the_opening() {
    // Nothing in the image separates them: where the two balloons met was a race, up to 2.3
    // voxels into the chamber (variant 6), until the union's depth saw the gap between them as
    // inside and the power diagram of its balls drew the boundary.
    for number in 0..8 {
        let variant = Family::VesselChamber.variant(number).unwrap();
        let objects = both_seeded(&variant);
        let voxel = variant.image.geometry().max_spacing();
        let end = end_beyond_opening(&variant, &objects[0].mesh);
        assert!(
            end.abs() <= 2.0 * voxel,
            "{number}: {end} mm from the opening"
        );
    }
}

#[test]
fn objects_simplified_together_report_the_second_half_of_the_run() {
    let variant = Family::TouchingPair.variant(1).unwrap();
    let request = ObjectsRequest {
        objects: vec![
            one(1, variant.seed()),
            one(2, variant.other_seed().unwrap()),
        ],
        ..ObjectsRequest::default()
    };
    let params = BalloonParams {
        simplify_error_mm: 0.2,
        ..BalloonParams::default()
    };
    let seen = Rc::new(RefCell::new(Vec::new()));
    let log = Rc::clone(&seen);
    let progress: ProgressCallback = Box::new(move |fraction, phase| {
        log.borrow_mut().push((fraction, phase));
        true
    });
    let objects = segment_objects(variant.image.view(), params, &request, Some(progress)).unwrap();
    assert_eq!(objects.len(), 2);
    let seen = seen.borrow();
    let first = seen
        .iter()
        .position(|(_, phase)| *phase == Phase::Simplification)
        .expect("the simplification reported");
    assert!(seen[..first].iter().all(|(f, _)| *f <= 0.5), "{seen:?}");
    assert!(seen[first..]
        .iter()
        .all(|(f, phase)| *phase == Phase::Simplification && (0.5..=1.0).contains(f)));
}
