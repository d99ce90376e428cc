# Set-up and entry points; every target creates or reuses .venv inside the checkout.
VENV ?= .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed-stamp
# A second venv with the newest bpy the add-on supports; `make test` also runs the Blender tests there.
BPY5_VERSION ?= 5.0.1
VENV5 ?= .venv-bpy5
PY5 := $(VENV5)/bin/python
STAMP5 := $(VENV5)/.installed-stamp-$(BPY5_VERSION)

.PHONY: demo test test-bpy4 test-bpy5 test-blender5 bench clean

$(STAMP): pyproject.toml
	test -x $(PY) || python3 -m venv $(VENV)
	$(PY) -m pip install -q --disable-pip-version-check -e '.[test]'
	touch $(STAMP)

# pyproject.toml's pins with bpy swapped for $(BPY5_VERSION); the package itself goes in without dependencies.
$(STAMP5): pyproject.toml
	test -x $(PY5) || python3.11 -m venv $(VENV5) || python3 -m venv $(VENV5)
	$(PY5) -m pip install -q --disable-pip-version-check $$($(PY5) -c "import tomllib; p = tomllib.load(open('pyproject.toml', 'rb'))['project']; print(' '.join('bpy==$(BPY5_VERSION)' if d.startswith('bpy==') else d for d in p['dependencies'] + p['optional-dependencies']['test']))")
	$(PY5) -m pip install -q --disable-pip-version-check --no-deps -e .
	touch $(STAMP5)

demo: $(STAMP)
	$(VENV)/bin/vto demo --size full --out out/demo

test: test-bpy4 test-bpy5

test-bpy4: $(STAMP)
	$(PY) -m pytest -q

test-bpy5: $(STAMP5)
	$(PY5) -m pytest -q -m blender

# Not in `make test`: bpy 5.2 is cp313 only, so it runs in a Debian trixie chroot (root, debootstrap, minutes).
test-blender5:
	bash scripts/test_blender5.sh

bench: $(STAMP)
	$(PY) -m benchmarks.run_all

clean:
	rm -rf out build *.egg-info
