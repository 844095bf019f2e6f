# texel-forest: `make demo` runs the pipeline on the fixtures, `make test` runs the tests.
# Every stage is a file-to-file rule with a depfile, the way a user's build would drive texel.

CARGO ?= cargo
TEXEL := $(or $(CARGO_TARGET_DIR),target)/release/texel
OUT := out
TREES := conifer broadleaf bare
TEXELS := $(TREES:%=$(OUT)/trees/%.texel)
VIEWS := $(foreach t,$(TREES),$(OUT)/trees/$(t).txt $(OUT)/trees/$(t).json \
           $(OUT)/trees/$(t)-projection-z.png $(OUT)/trees/$(t)-projection-y.png \
           $(OUT)/trees/$(t)-slice-y10.png)

.PHONY: demo test bench accuracy report budget flicker fixtures formats-check animation clean FORCE
.DELETE_ON_ERROR:

FOREST := $(OUT)/forest.instances $(OUT)/forest.txt $(OUT)/forest.json $(OUT)/forest-map.png \
          $(OUT)/forest.exr $(OUT)/forest.glb $(OUT)/forest-mattes.exr

# The same trees on a heightmap terrain (a 16-bit grey PNG, as terrain tools export).
HEIGHTMAP := $(OUT)/heightmap-forest.instances $(OUT)/heightmap-forest.exr

demo: $(TEXELS) $(VIEWS) $(FOREST) $(HEIGHTMAP)
	@echo "demo: outputs under $(OUT)/ (trees/: texels, summaries, pictures; forest.*: the placed forest and its map)"

# Release speed, with overflow checks and debug assertions on (the `ci` profile).
test:
	$(CARGO) test --profile ci

# Set TEXEL_BASELINE to another build's texel binary to time both in turn (render bench).
bench:
	$(CARGO) bench --bench bake --bench place --bench render --bench million --bench bvh

accuracy:
	$(CARGO) run --release --example accuracy -- --anisotropy --heights

# Speed against error for every method and setting (report/; the reference renders are
# cached in report/cache/). About 35 minutes on 2 cores the first time (stop 29: 33).
report: $(TEXEL)
	$(CARGO) run --release --example report

# The texel method's error split into coverage, shading, shadows and noise, alone
# (report/error_budget.*; part of `make report`).
budget: $(TEXEL)
	$(CARGO) run --release --example report -- --budget

# The fly-in: the demo forest from the far view down to a near one (fixtures/paths/flyin.json,
# 4 s at 12 frames a second: 49 frames), drawn by the hybrid method, into out/flyin/ with an
# animated preview. Each frame is its own file and the same bytes however the frames are
# split between runs (`--frames A..B`). (`#` stays in the recipe: in a variable it starts a
# comment.)
animation: $(OUT)/flyin.png

$(OUT)/flyin.png: $(OUT)/forest.instances fixtures/paths/flyin.json $(TEXEL)
	$(TEXEL) render $< --camera-path fixtures/paths/flyin.json --fps 12 --method hybrid \
	    --width 640 --height 360 --aov canopy,lod -o $(OUT)/flyin/frame.####.exr \
	    --preview $(OUT)/flyin/frame.####.png --depfile $(OUT)/flyin/frames.d
	$(TEXEL) animate $(OUT)/flyin/frame.*.png -o $@ --fps 12

# Flicker along the fly-in for each method, in the canopy and in the hybrid's transition band
# (report/flicker.png; part of `make report`).
flicker: $(TEXEL)
	$(CARGO) run --release --example report -- --flicker

# Regenerates the procedural fixtures and the golden .texel; tests check they match.
fixtures:
	$(CARGO) run --release --example make_fixtures -- fixtures

# The reference reader (formats/reference/, written from the specs alone; needs Python's
# zstandard module) against the golden files and the invalid corpus.
formats-check:
	python3 formats/reference/read_formats.py --check-golden \
	    fixtures/formats/conifer-8.texel fixtures/formats/forest-12.instances \
	    fixtures/formats/forest-12-heightmap.instances
	python3 formats/reference/read_formats.py --expect-invalid fixtures/formats/invalid/* >/dev/null

clean:
	rm -rf $(OUT)

# cargo decides whether the binary is stale; Make re-reads its timestamp afterwards.
$(TEXEL): FORCE
	$(CARGO) build --release --bin texel

$(OUT)/trees/%.texel: fixtures/trees/%.glb $(TEXEL)
	$(TEXEL) bake $< -o $@ --depfile $@.d
$(OUT)/trees/%.texel: fixtures/trees/%.gltf $(TEXEL)
	$(TEXEL) bake $< -o $@ --depfile $@.d

$(OUT)/trees/%.txt: $(OUT)/trees/%.texel
	$(TEXEL) inspect $< > $@
$(OUT)/trees/%.json: $(OUT)/trees/%.texel
	$(TEXEL) inspect $< --json > $@
$(OUT)/trees/%-projection-z.png: $(OUT)/trees/%.texel
	$(TEXEL) inspect $< --projection z -o $@
$(OUT)/trees/%-projection-y.png: $(OUT)/trees/%.texel
	$(TEXEL) inspect $< --projection y -o $@
$(OUT)/trees/%-slice-y10.png: $(OUT)/trees/%.texel
	$(TEXEL) inspect $< --slice y=10 -o $@

# The species file names its texels relative to itself: it lives beside out/trees/.
$(OUT)/species.json: fixtures/species/forest.json
	@mkdir -p $(OUT)
	cp $< $@

$(OUT)/forest.instances: fixtures/terrain/mountain.glb $(OUT)/species.json $(TEXELS) $(TEXEL)
	$(TEXEL) place $< --species $(OUT)/species.json -o $@ --seed 1 --depfile $@.d
$(OUT)/forest.txt: $(OUT)/forest.instances
	$(TEXEL) inspect $< > $@
$(OUT)/forest.json: $(OUT)/forest.instances
	$(TEXEL) inspect $< --json > $@
$(OUT)/forest-map.png: $(OUT)/forest.instances
	$(TEXEL) inspect $< --map -o $@

# The paper's figure 6 view: the whole forested mountain from afar in afternoon light.
$(OUT)/forest.exr: $(OUT)/forest.instances $(TEXEL)
	$(TEXEL) render $< -o $@ --preview $(OUT)/forest.png --width 1280 --height 720 --depfile $@.d

# The forest for other tools: the tree models instanced per tree over the terrain (glTF), and
# a table of the trees.
$(OUT)/forest.glb: $(OUT)/forest.instances $(TEXEL)
	$(TEXEL) export $< -o $@ --with-terrain --csv $(OUT)/forest-trees.csv --depfile $@.d

# The same view with ID mattes for compositing: Cryptomatte by species and by tree.
$(OUT)/forest-mattes.exr: $(OUT)/forest.instances $(TEXEL)
	$(TEXEL) render $< -o $@ --width 640 --height 360 --aov canopy,cryptomatte --depfile $@.d

# The heightmap says neither its extent nor its heights: the flags do, and the forest records
# them, so the render needs none.
$(OUT)/heightmap-forest.instances: fixtures/terrain/valley.png $(OUT)/species.json $(TEXELS) $(TEXEL)
	$(TEXEL) place $< --terrain-size 1000,1000 --height-range 100,600 \
	    --species $(OUT)/species.json -o $@ --seed 1 --depfile $@.d
$(OUT)/heightmap-forest.exr: $(OUT)/heightmap-forest.instances $(TEXEL)
	$(TEXEL) render $< -o $@ --preview $(OUT)/heightmap-forest.png --width 640 --height 360 \
	    --depfile $@.d

-include $(TEXELS:%=%.d) $(OUT)/forest.instances.d $(OUT)/forest.exr.d $(OUT)/forest.glb.d \
    $(OUT)/forest-mattes.exr.d $(OUT)/heightmap-forest.instances.d $(OUT)/heightmap-forest.exr.d
