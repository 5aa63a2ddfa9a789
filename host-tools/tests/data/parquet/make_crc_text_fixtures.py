"""Writes the copied-column checksum fixtures of host-tools/tests/hostile_inputs.rs (issue 19).

crc_text.parquet: 200 pair rows with a text column `id` in front, 2 row groups, every page with
its CRC-32 (write_page_checksum). Parquet -> Parquet copies `id` without decoding it.
crc_text_flipped.parquet: the same file with one bit of the last byte of `id`'s column chunk in
row group 1 flipped (page data, not a header), which pyarrow with
page_checksum_verification=True refuses.

Run with pyarrow (scripts/setup.sh python, then .cache/pyenv/bin/python make_crc_text_fixtures.py).
"""
import pyarrow as pa
import pyarrow.parquet as pq

COLUMNS = "x_i,y_i,vx_i,vy_i,hx_i,hy_i,acc_i,length_i,width_i,x_j,y_j,vx_j,vy_j,hx_j,hy_j,acc_j,length_j,width_j".split(",")
VALUES = dict(vx_i=15.0, hx_i=1.0, length_i=4.5, width_i=1.8, vx_j=10.0, hx_j=1.0, length_j=4.5, width_j=1.8)

columns = {"id": [f"pair-{i:04d}" for i in range(200)]}
columns.update({c: [10.0 + (i % 37) if c == "x_j" else VALUES.get(c, 0.0) for i in range(200)] for c in COLUMNS})
table = pa.table(columns)
pq.write_table(table, "crc_text.parquet", row_group_size=100, write_page_checksum=True,
               compression="NONE", use_dictionary=False)

chunk = pq.ParquetFile("crc_text.parquet").metadata.row_group(1).column(0)
assert chunk.path_in_schema == "id"
start = chunk.data_page_offset if chunk.dictionary_page_offset is None else chunk.dictionary_page_offset
last = start + chunk.total_compressed_size - 1
flipped = bytearray(open("crc_text.parquet", "rb").read())
flipped[last] ^= 0x01
open("crc_text_flipped.parquet", "wb").write(bytes(flipped))
assert not pq.read_table("crc_text_flipped.parquet").equals(table), "the flip changes a value"
try:
    pq.read_table("crc_text_flipped.parquet", page_checksum_verification=True)
except OSError as e:
    print(f"flipped the last byte of id in row group 1 (offset {last}): {e}")
else:
    raise SystemExit("pyarrow read the flipped file")
