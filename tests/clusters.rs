//! Clusters of a cloud of spheres (`src/cloud.rs`): spheres whose surface gap is below a
//! tenth of the smaller radius are in contact, and the clusters are the connected groups
//! of that relation. Known answers on small configurations: a chain counts once whatever
//! its order along the sweep axis, the threshold is that of the smaller radius, and a
//! lattice is one cluster or one per sphere depending on its gaps.
use grainflow::cloud::{clusters, CONTACT_GAP_FRACTION};

#[test]
fn a_chain_is_one_cluster_and_a_lone_sphere_another() {
    // three spheres of r = 1 in a chain along x with gaps 0.05 (touching by the rule),
    // listed out of order, and one 5 away
    let position = [
        [4.1, 0.0, 0.0],
        [0.0, 0.0, 0.0],
        [2.05, 0.0, 0.0],
        [4.1, 7.0, 0.0],
    ];
    let radius = [1.0; 4];
    let (labels, count) = clusters(&position, &radius, CONTACT_GAP_FRACTION);
    assert_eq!(count, 2);
    assert_eq!(labels, vec![0, 0, 0, 1]);
}

#[test]
fn the_contact_gap_is_a_tenth_of_the_smaller_radius() {
    // r = 1 and r = 0.2: contact below a gap of 0.02, not 0.1
    let radius = [1.0, 0.2];
    for (gap, count) in [(0.019, 1), (0.021, 2), (0.09, 2)] {
        let position = [[0.0, 0.0, 0.0], [0.0, 0.0, 1.2 + gap]];
        assert_eq!(
            clusters(&position, &radius, CONTACT_GAP_FRACTION).1,
            count,
            "gap {gap}"
        );
    }
    // spheres that overlap are in contact
    let position = [[0.0, 0.0, 0.0], [0.0, 1.1, 0.0]];
    assert_eq!(clusters(&position, &radius, CONTACT_GAP_FRACTION).1, 1);
}

#[test]
fn a_lattice_is_one_cluster_when_its_gaps_are_below_the_contact_gap() {
    let r = 0.25;
    let lattice = |spacing: f64| -> Vec<[f64; 3]> {
        let mut p = Vec::new();
        for k in 0..4 {
            for j in 0..4 {
                for i in 0..4 {
                    p.push([i, j, k].map(|n| f64::from(n) * spacing));
                }
            }
        }
        p
    };
    let radius = vec![r; 64];
    // gaps 0.05 r: one cluster; 0.15 r: 64 (the diagonals are farther still)
    assert_eq!(
        clusters(&lattice(2.05 * r), &radius, CONTACT_GAP_FRACTION).1,
        1
    );
    assert_eq!(
        clusters(&lattice(2.15 * r), &radius, CONTACT_GAP_FRACTION).1,
        64
    );
    // two touching columns far apart along x, joined along z only: 2 clusters; the
    // sweep along x must still find the pairs of equal x
    let mut two: Vec<[f64; 3]> = (0..5).map(|k| [0.0, 0.0, f64::from(k) * 2.0 * r]).collect();
    two.extend((0..5).map(|k| [3.0, 0.0, f64::from(k) * 2.0 * r]));
    let (labels, count) = clusters(&two, &[r; 10], CONTACT_GAP_FRACTION);
    assert_eq!(count, 2);
    assert!(labels[..5].iter().all(|&l| l == 0) && labels[5..].iter().all(|&l| l == 1));
}

#[test]
fn no_spheres_no_clusters() {
    assert_eq!(clusters(&[], &[], CONTACT_GAP_FRACTION), (vec![], 0));
}
