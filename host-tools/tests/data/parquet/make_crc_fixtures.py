"""Writes the page-checksum fixtures of host-tools/tests/hostile_inputs.rs (issue 21, case N60).

crc.parquet: 200 pair rows in 2 row groups, every page with its CRC-32 (write_page_checksum).
crc_flipped.parquet: the same file with one bit of one data page flipped, chosen so that a
reader that skips the checksums reads a changed value without any error, and pyarrow with
page_checksum_verification=True refuses the file.

Run with pyarrow (python3 -m venv /tmp/v && /tmp/v/bin/pip install pyarrow):
    /tmp/v/bin/python make_crc_fixtures.py
"""
import pyarrow as pa
import pyarrow.parquet as pq

COLUMNS = "x_i,y_i,vx_i,vy_i,hx_i,hy_i,acc_i,length_i,width_i,x_j,y_j,vx_j,vy_j,hx_j,hy_j,acc_j,length_j,width_j".split(",")
VALUES = dict(vx_i=15.0, hx_i=1.0, length_i=4.5, width_i=1.8, vx_j=10.0, hx_j=1.0, length_j=4.5, width_j=1.8)

table = pa.table({c: [10.0 + (i % 37) if c == "x_j" else VALUES.get(c, 0.0) for i in range(200)] for c in COLUMNS})
pq.write_table(table, "crc.parquet", row_group_size=100, write_page_checksum=True, compression="NONE")

good = open("crc.parquet", "rb").read()
# From the middle on: a page of the second row group, not the first column.
for offset in range(len(good) // 3, len(good) - 8):
    for bit in range(8):
        flipped = bytearray(good)
        flipped[offset] ^= 1 << bit
        open("crc_flipped.parquet", "wb").write(bytes(flipped))
        try:
            unchecked = pq.read_table("crc_flipped.parquet")
        except Exception:
            continue
        if unchecked.equals(table):
            continue
        try:
            pq.read_table("crc_flipped.parquet", page_checksum_verification=True)
        except Exception as e:
            print(f"flipped bit {bit} of byte {offset}: {e}")
            raise SystemExit(0)
raise SystemExit("no silent flip found")
