"""Tests of scripts/perf-summary.py's floor model: `python3 -m unittest scripts/test_perf_summary.py`
from the repository root (standard library only)."""
import importlib.util
import glob
import json
import os
import tempfile
import unittest

_spec = importlib.util.spec_from_file_location(
    "perf_summary", os.path.join(os.path.dirname(os.path.abspath(__file__)), "perf-summary.py")
)
ps = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(ps)


def run_json(passes, light_pairs=10, adapter="NVIDIA H200 (Vulkan, DiscreteGpu, driver NVIDIA 580.159.04)"):
    """A hand-made bench JSON: 32x16 pixels in two 16-px tiles, 4 lights, 100 triangles."""
    return {
        "config": {
            "adapter": adapter, "resolution": "32x16", "width": 32, "height": 16, "tile_size": 16,
            "msaa": 1, "triangles": 100, "point_lights": 4, "spot_lights": 0, "commit": "test",
        },
        "passes": [{"pass": name, "median_ms": ms} for name, ms in passes],
        "total_gpu_median_ms": sum(ms for _, ms in passes),
        "light_pairs": light_pairs,
        "edge_pixels": None,
        "dropped_frames": 0,
    }


# The H200 by hand: 132 SMs x 4 schedulers x 32 lanes x 1.98 GHz; MUFU 132 x 16 x 1.98 GHz.
ISSUE = 132 * 4 * 32 * 1.98e9
MUFU = 132 * 16 * 1.98e9
HBM = 4.8e12


class FloorModel(unittest.TestCase):
    def test_visibility_shade_floor_by_hand(self):
        run = run_json([("visibility.shade", 1.0)])
        # 512 pixels; 10 tile-light pairs over 2 tiles: 5 lights a pixel, 2,560 pixel-light pairs.
        # Issue: 330 a pixel + 17 a pair (the range test) = 168,960 + 43,520 instructions.
        issue = (330 * 512 + 17 * 2560) / ISSUE
        # Bytes: ID 4 + HDR 8 a pixel, 4 a list index: 6,184 B, far below the issue time.
        self.assertLess((12 * 512 + 4 * 10) / HBM, issue)
        t, kind, full = ps.pass_floor(ps.match("visibility.shade"), ps.quantities(run), ps.gpu_of(run["config"]["adapter"]))
        self.assertAlmostEqual(t, issue, delta=issue * 1e-9)
        self.assertEqual(kind, "issue")
        # The full path adds 92 a pair (5 MUFU, not the bound here).
        full_hand = (330 * 512 + 109 * 2560) / ISSUE
        self.assertGreater(full_hand, 5 * 2560 / MUFU)
        self.assertAlmostEqual(full, full_hand, delta=full_hand * 1e-9)
        # The table's cells: floor ms to 3 figures and the ratio.
        cells = ps.pass_row(run, run["passes"][0], ps.gpu_of(run["config"]["adapter"]))
        self.assertEqual(cells[0], f"{issue * 1e3:.3g}")
        self.assertEqual(cells[1], f"{1.0 / (issue * 1e3):.1f}")

    def test_tonemap_is_bandwidth_bound(self):
        run = run_json([("tonemap", 0.01)])
        # 12 B a pixel at 4.8 TB/s beats 45 instructions and 9 MUFU ops a pixel.
        bw = 12 * 512 / HBM
        self.assertGreater(bw, 45 * 512 / ISSUE)
        self.assertGreater(bw, 9 * 512 / MUFU)
        t, kind, _ = ps.pass_floor(ps.match("tonemap"), ps.quantities(run), ps.gpu_of(run["config"]["adapter"]))
        self.assertAlmostEqual(t, bw, delta=bw * 1e-9)
        self.assertEqual(kind, "bandwidth")

    def test_h100_numbers_from_the_adapter(self):
        gpu = ps.gpu_of("NVIDIA H100 80GB HBM3 (Vulkan, DiscreteGpu, driver NVIDIA 580.159.04)")
        self.assertEqual(gpu["bytes_per_s"], 3.35e12)
        self.assertIsNone(ps.gpu_of("llvmpipe (LLVM 15.0.7, 256 bits)"))

    def test_unknown_pass_gets_no_floor(self):
        run = run_json([("made_up.pass", 0.5)])
        cells = ps.pass_row(run, run["passes"][0], ps.gpu_of(run["config"]["adapter"]))
        self.assertEqual(cells[0], "no floor")
        self.assertIn("not in the model", cells[4])

    def test_missing_pairs_is_a_clear_message(self):
        run = run_json([("visibility.shade", 1.0), ("tonemap", 0.01)], light_pairs=None)
        run["_file"] = "sum-test.json"
        said = []
        cells = ps.pass_row(run, run["passes"][0], ps.gpu_of(run["config"]["adapter"]), said.append)
        self.assertEqual(cells[0], "no floor")
        self.assertEqual(cells[4], "no light_pairs in the JSON")
        self.assertEqual(len(said), 1)
        self.assertIn("sum-test.json: no light_pairs", said[0])
        # Passes that need no pairs still get their floor.
        self.assertNotEqual(ps.pass_row(run, run["passes"][1], ps.gpu_of(run["config"]["adapter"]))[0], "no floor")

    def test_table_and_write(self):
        with tempfile.TemporaryDirectory() as d:
            with open(os.path.join(d, "sum-f9-visibility-4096.json"), "w") as f:
                json.dump(run_json([("visibility.shade", 1.0), ("made_up.pass", 0.5)]), f)
            text = ps.table(d)
            self.assertIn("| Figure 9 scene, 4,096 lights | visibility buffer | made_up.pass | 0.500 | no floor |", text)
            self.assertIn("What the floor leaves out", text)
            doc = os.path.join(d, "PERF.md")
            with open(doc, "w") as f:
                f.write("before\n<!-- summary:begin -->\nold\n<!-- summary:end -->\nafter\n")
            ps.write_block(doc, text)
            with open(doc) as f:
                out = f.read()
            self.assertTrue(out.startswith("before\n<!-- summary:begin -->\n"))
            self.assertTrue(out.endswith("<!-- summary:end -->\nafter\n"))
            self.assertNotIn("\nold\n", out)

    def test_large_raster_priced_by_its_tiles(self):
        run = run_json([("visibility.raster.large", 0.1)])
        run["large_tiles"] = 1000
        t, kind, _ = ps.pass_floor(ps.match("visibility.raster.large"), ps.quantities(run), ps.gpu_of(run["config"]["adapter"]))
        self.assertAlmostEqual(t, 1000 * 20400 / ISSUE, delta=t * 1e-9)
        self.assertEqual(kind, "issue")
        del run["large_tiles"]
        with self.assertRaises(ps.MissingCount):
            ps.pass_floor(ps.match("visibility.raster.large"), ps.quantities(run), ps.gpu_of(run["config"]["adapter"]))

    def test_repeats_take_the_median(self):
        with tempfile.TemporaryDirectory() as d:
            for rep, ms in [(1, 1.3), (2, 1.1), (3, 1.2)]:
                with open(os.path.join(d, f"sum-f9-visibility-4096-r{rep}.json"), "w") as f:
                    json.dump(run_json([("visibility.shade", ms)]), f)
            runs = ps.median_runs(sorted(glob.glob(os.path.join(d, "sum-*.json"))))
            self.assertEqual(list(runs), ["f9-visibility-4096"])
            self.assertEqual(runs["f9-visibility-4096"]["total_gpu_median_ms"], 1.2)
            self.assertTrue(runs["f9-visibility-4096"]["_file"].endswith("-r3.json"))
            self.assertIn("**1.200** [3 repeats 1.100-1.300]", ps.table(d))


if __name__ == "__main__":
    unittest.main()
