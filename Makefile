# Set-up and the two everyday commands. Needs only Python 3.11 (or newer) on the PATH.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: demo test typecheck docs chromium postgres slurm lint bench seed-paper clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

demo: $(STAMP)  ## a small study (DE, GA, random search on the seed curves), then its report
	$(BIN)/metaknot run -m experiment=smoke launcher=joblib
	$(BIN)/metaknot report results/smoke

test: $(STAMP) typecheck chromium postgres  ## the type check, then the whole test suite (slow studies at CI size)
	$(BIN)/python .ci/warm-kernels  # the compiled kernels' cache, once, before parallel tests
	$(BIN)/python -m pytest -n 2 --dist loadgroup -q

typecheck: $(STAMP)  ## the static type check: mypy as configured in pyproject.toml, 0 errors
	$(BIN)/python .ci/mypy-packages
	$(BIN)/mypy

docs: $(STAMP)  ## the documentation site into site/, strict: a broken link or reference fails
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict --site-dir site

chromium:  ## the headless browser the report test opens report.html in (Debian's chromium)
	@command -v chromium >/dev/null || { apt-get update -q && \
	  apt-get install -y -q --no-install-recommends chromium; } || \
	  { echo "install Debian's chromium (apt-get install chromium) for the report test"; exit 1; }

postgres:  ## the PostgreSQL server the distributed-tuning test starts on 127.0.0.1 (Debian's postgresql)
	@ls /usr/lib/postgresql/*/bin/initdb >/dev/null 2>&1 || { apt-get update -q && \
	  apt-get install -y -q --no-install-recommends postgresql; } || \
	  { echo "install Debian's postgresql (apt-get install postgresql) for the tuning test"; exit 1; }

slurm:  ## a one-node SLURM cluster on 127.0.0.1 for the SLURM test (Debian's slurm and MariaDB for sacct); stop it with .ci/slurm stop
	@.ci/slurm start

lint: $(STAMP)
	$(BIN)/ruff check .

bench: $(STAMP)  ## kernel speed against scipy; see benchmarks/ for runs, sweeps and quality
	$(BIN)/python benchmarks/bench_evaluate.py

seed-paper: $(STAMP)  ## the seed paper's study over 30 seeds (about 6 minutes on 2 cores: 5 min 37 s measured), and its report
	$(BIN)/metaknot run -m experiment=seed_paper launcher=joblib
	$(BIN)/metaknot report results/seed_paper

clean:
	rm -rf $(VENV) build site *.egg-info .pytest_cache
