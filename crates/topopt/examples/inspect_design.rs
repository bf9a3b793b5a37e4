//! Geometry checks of a density field: `cargo run --release -p flexstage-topopt --example
//! inspect_design -- FILE.json [element_size_mm]` with a JSON object `{ "nl", "nw", "rho" }`
//! (a design.json works): thinnest member, narrowest gap (with where), one-node hinges and the
//! mirror asymmetry, and an ASCII picture.

use flexstage_topopt::geometry::{Field, member_sizes, mirror_asymmetry, one_node_hinges};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let text = std::fs::read_to_string(&args[1]).expect("read the design");
    let v: serde_json::Value = serde_json::from_str(&text).expect("JSON");
    let (nl, nw) = (
        v["nl"].as_u64().unwrap() as usize,
        v["nw"].as_u64().unwrap() as usize,
    );
    let rho: Vec<f64> = v["rho"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    let h = args
        .get(2)
        .and_then(|a| a.parse::<f64>().ok())
        .unwrap_or(120.0 / nl as f64)
        * 1e-3;
    let f = Field {
        nl,
        nw,
        h: (h, h),
        rho: &rho,
    };
    for j in (0..nw).rev() {
        let row: String = (0..nl)
            .map(|i| match rho[i * nw + j] {
                r if r >= 0.5 => '#',
                r if r > 0.1 => '+',
                _ => '.',
            })
            .collect();
        println!("{row}");
    }
    let (t, g) = member_sizes(&f, 4);
    println!("thinnest member {t:?}\nnarrowest gap {g:?}");
    println!("one-node hinges {:?}", one_node_hinges(&f));
    println!("mirror asymmetry {:e}", mirror_asymmetry(&f));
}
