//! In-process throughput of `riskctl ssm`'s engine: the CSV pipeline (one thread and all cores)
//! and the Arrow kernel, on the golden pairs repeated to 59,000 rows. Whole-process figures on
//! 1 M real pairs: scripts/bench-ssm.sh. Results: docs/benchmarks.md.
use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use riskscore_data::ssm_csv::{score_csv, SsmOptions};

fn golden_repeated(times: usize) -> (Vec<u8>, u64) {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../tests/data/golden_surrogates.csv"
    ))
    .expect("golden file");
    let (header, body) = text.split_once('\n').expect("header");
    let rows = body.lines().count() * times;
    (
        format!("{header}\n{}", body.repeat(times)).into_bytes(),
        rows as u64,
    )
}

fn csv_pipeline(c: &mut Criterion) {
    let (input, rows) = golden_repeated(20);
    let mut group = c.benchmark_group("ssm_csv");
    group.throughput(Throughput::Elements(rows));
    group.sample_size(10);
    for threads in [1, 0] {
        let name = if threads == 1 {
            "1 thread"
        } else {
            "all cores"
        };
        group.bench_function(name, |b| {
            let mut out = Vec::with_capacity(input.len() * 2);
            b.iter(|| {
                out.clear();
                let options = SsmOptions {
                    threads,
                    ..SsmOptions::default()
                };
                score_csv(input.as_slice(), &mut out, options, |_| {}).expect("scores");
            })
        });
    }
    group.finish();
}

#[cfg(feature = "parquet")]
fn arrow_kernel(c: &mut Criterion) {
    use riskscore_eval::arrow_kernel::{pair_columns, ssm_kernel};
    use riskscore_eval::parquet_io::CsvBatches;
    let (input, _) = golden_repeated(20);
    let mut batches = CsvBatches::new(input.as_slice(), &SsmOptions::default()).expect("header");
    let columns = batches.columns().clone();
    let batch = batches.next_batch(|_| {}).expect("read").expect("a batch");
    let _ = pair_columns(&batch.schema()).expect("pair columns");
    let mut group = c.benchmark_group("arrow_kernel");
    group.throughput(Throughput::Elements(batch.num_rows() as u64));
    group.sample_size(10);
    group.bench_function("ssm_kernel", |b| {
        b.iter(|| ssm_kernel(&columns, &batch, 0).expect("kernel"))
    });
    group.finish();
}

#[cfg(not(feature = "parquet"))]
fn arrow_kernel(_: &mut Criterion) {}

criterion_group!(benches, csv_pipeline, arrow_kernel);
criterion_main!(benches);
