# MorphoNavi: `make run` starts the console (simulated robot, demo room); `make test` runs every test.
# Both create .venv and install what they need on a machine that has only Python 3.10+: `make run` only what
# running needs, `make test` also the test extras (pytest, playwright, scikit-image, ...).
PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed-run
TEST_STAMP := $(VENV)/.installed-test

.PHONY: run test bench browser clean

run: $(STAMP)
	$(VENV)/bin/morphonavi console

test: $(TEST_STAMP) browser
	$(PY) -m pytest -q -p no:cacheprovider

bench: $(STAMP)
	$(PY) bench/planner.py

$(PY):
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip

$(STAMP): pyproject.toml | $(PY)
	$(PY) -m pip install -q -e .
	touch $(STAMP)

$(TEST_STAMP): pyproject.toml | $(PY)
	$(PY) -m pip install -q -e '.[test]'
	touch $(STAMP) $(TEST_STAMP)

# Debian's Chromium for the end-to-end browser test (skipped with a reason when it cannot be had).
browser:
	@if [ ! -x /usr/bin/chromium ] && [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
		echo "installing Debian chromium for the browser test..."; \
		(apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null) \
		|| echo "chromium could not be installed: the browser test will be skipped"; \
	fi

clean:
	rm -rf $(VENV) build *.egg-info
