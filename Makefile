# aquaspec: make setup | make test | make demo | make bench
VENV   ?= .venv
PY     := $(VENV)/bin/python
DEBS   := mesa-vulkan-drivers libvulkan1 libllvm19 xvfb xdotool
EXTRAS := test,exr,validation,view,synth
export XDG_RUNTIME_DIR ?= $(CURDIR)/.xdg-runtime

.PHONY: setup debs test demo bench clean

setup: debs $(VENV)/.installed

# Installs the Debian packages when they are missing and we are root (otherwise
# prints the exact command): Mesa's lavapipe Vulkan driver, so wgpu runs on
# machines without a GPU, LLVM 19 for Mitsuba's llvm_ad_spectral variant
# (the validation's path tracer), and Xvfb and xdotool for the test that drives
# `aquaspec view` in a real window.
debs:
	@missing=""; for p in $(DEBS); do dpkg -s $$p >/dev/null 2>&1 || missing="$$missing $$p"; done; \
	if [ -n "$$missing" ]; then \
	  if [ "$$(id -u)" = 0 ]; then \
	    echo "installing Debian packages:$$missing"; \
	    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $$missing; \
	  else \
	    echo "missing Debian packages:$$missing"; \
	    echo "run: sudo apt-get install -y$$missing"; \
	  fi; \
	fi

$(VENV)/.installed: pyproject.toml
	test -x $(PY) || python3 -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e ".[$(EXTRAS)]"
	touch $@

test: setup
	@mkdir -p $(XDG_RUNTIME_DIR)
	$(PY) -m pytest -q -rs

demo: setup
	@mkdir -p $(XDG_RUNTIME_DIR)
	$(VENV)/bin/aquaspec render --water IB --depth 5 --size 1280x720 --bands 16 -o demo.png

bench: setup
	@mkdir -p $(XDG_RUNTIME_DIR)
	$(VENV)/bin/aquaspec bench

clean:
	rm -rf $(VENV) .pytest_cache .xdg-runtime
