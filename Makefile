SHELL := /bin/bash
# One entry point.  `make test` and `make book` set up a pinned virtual environment
# (.venv, from requirements-lock.txt) on first use, so a fresh machine needs only Python 3.11.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
# MPLBACKEND is deliberately not exported: notebook kernels must use the inline backend so
# that nbval sees the same figure outputs as were stored (tests/conftest.py selects Agg).
export PYDEVD_DISABLE_FILE_VALIDATION := 1

.PHONY: venv kernels kernels-native kernels-generic test check test-unit test-notebooks test-notebooks-other book book-clean book-student book-student-html screenshots \
	pdf pdf-if-tex pdfs-if-tex datasets execute clean rerun rerun-examples

venv: $(STAMP)

# Python writes the byte code of each module it imports, once, where the next process finds it:
# where PYTHONDONTWRITEBYTECODE is set (as on the book's machine) it never did, and every process
# compiled every module it imported from source again: each notebook's kernel, pool worker and
# test subprocess (measured 2026-12-04: numpy, pandas and matplotlib imported in 2.05 s instead
# of 0.7 s; a fresh process to its first steady state 2.7 s instead of 1.0 s).  Written on first
# import, the byte code covers only what the book uses: byte-compiling the whole environment at
# install (compileall on both cores) took 19 s of a fresh `make test` (12 000 modules).
unexport PYTHONDONTWRITEBYTECODE

$(STAMP): requirements-lock.txt pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet --no-compile -r requirements-lock.txt
	$(BIN)/python -m pip install --quiet --no-deps --no-build-isolation -e .
	touch $(STAMP)

## make test: nbval (strict) over every notebook in book/ first (it re-executes every cell: the
## reproducibility check), twice: as the machine is and in a second numerical environment
## (test-notebooks-other: numba generic target, one BLAS thread); then
## the PDF (when TeX is there, so that the book links it), the
## book (warnings are errors), and the library's unit tests, the PDF and edition tests (the
## student edition) and the browser test of the built book (tests/).  Once nbval has found
## every stored output reproduced, the execution cache is seeded with the stored outputs
## (fivebar_build.py seed-cache), so the builds do not execute every notebook a second time.
## A notebook that does not reproduce stops `make test` there (the book would show it).
## TEST_JOBS: worker processes of nbval and tests/ (pytest-xdist; a notebook, and a test file,
## stays on one worker, in order).  The book's machine has 2 cores; TEST_JOBS=0 runs in-process.
## The single-threaded builds run two at a time (the machine has 2 cores): the data downloads
## beside the first nbval pass, the two editions' PDFs together, then the two editions' HTML
## (the student edition: tests/test_editions.py finds it built and up to date).
TEST_JOBS ?= 2
## WORKER_THREADS: the BLAS threads of each worker, the machine's cores shared out among the
## workers (2 cores, 2 workers: 1 each).  Left to OpenBLAS's default, each of the two workers
## started a thread per core, four busy threads on two cores: measured on 2026-12-03 (idle
## machine, nbval of every notebook), 3 min 24 s with the default against 2 min 06 s with one
## thread a worker, the same 420 cells passing.  Used by the first nbval pass, tests/ and
## make check: make check alternated with and without it (idle machine, 2026-12-04) took 62 and
## 68 s with one thread a worker against 82 and 74 s with the default.
WORKER_THREADS ?= $(shell n=$$(nproc 2>/dev/null || echo 1); j=$(TEST_JOBS); [ "$$j" -gt 0 ] 2>/dev/null || j=1; \
	t=$$(( n / j )); [ $$t -ge 1 ] && echo $$t || echo 1)
THREADS := OPENBLAS_NUM_THREADS=$(WORKER_THREADS) OMP_NUM_THREADS=$(WORKER_THREADS) MKL_NUM_THREADS=$(WORKER_THREADS)
BUILD_JOBS ?= 2
## $(call timed,PART): a recipe line that says, when it ends, how long it took (make test's parts)
timed = @s=$$(date +%s); trap 'echo "make test: $(1): $$(( $$(date +%s) - s )) s"' EXIT;
test: venv
	$(call timed,the compiled kernels of both numerical environments) \
	$(MAKE) --no-print-directory -j$(BUILD_JOBS) kernels
	$(call timed,nbval with the data downloads beside it) \
	$(MAKE) --no-print-directory -j$(BUILD_JOBS) test-notebooks datasets
	$(call timed,nbval in the second numerical environment) $(MAKE) --no-print-directory test-notebooks-other
	$(call timed,execution cache seeded) $(BIN)/python book/_ext/fivebar_build.py seed-cache
	$(call timed,the two PDFs) $(MAKE) --no-print-directory pdfs-if-tex
	$(call timed,the two HTML editions) $(MAKE) --no-print-directory -j$(BUILD_JOBS) -Otarget book book-student-html
	$(call timed,tests/) \
	$(THREADS) $(BIN)/python -m pytest -p no:cacheprovider -n $(TEST_JOBS) --dist loadfile tests -q --durations=25

## make check: the fast unit tests (not marked slow; no notebooks, no book, no browser), for the
## edit-test loop: about a minute on 2 cores.  `make test` runs everything.
check: venv
	$(THREADS) $(BIN)/python -m pytest -p no:cacheprovider -n $(TEST_JOBS) --dist loadfile tests -q -m "not slow" \
	--ignore=tests/test_browser.py --ignore=tests/test_editions.py --ignore=tests/test_pdf.py

## make test-unit: only the library's unit tests (no book, no browser)
test-unit: venv
	$(BIN)/python -m pytest -p no:cacheprovider tests -q --ignore=tests/test_browser.py

## The notebooks go to the workers longest first (book/conftest.py; --no-loadscope-reorder keeps
## that order instead of xdist's, by number of cells), so that no long one runs alone at the end.
NBVAL_DIST := --dist loadscope --no-loadscope-reorder
test-notebooks: venv
	$(THREADS) $(BIN)/python -m pytest -p no:cacheprovider -n $(TEST_JOBS) $(NBVAL_DIST) book --nbval --nbval-current-env \
	--nbval-sanitize-with tests/nbval_sanitize.cfg -q

## make test-notebooks-other: nbval (strict) again in a second numerical environment that rounds
## differently: numba's generic target (no fused multiply-add, no AVX; its own cache directory,
## _build/numba-generic) and one BLAS thread.  Every stored output must survive it: a number
## printed to a digit that round-off moves fails here (book/run.md, "Check the book on your
## machine").  OPENBLAS_CORETYPE is left as the machine sets it.
GENERIC := NUMBA_CPU_NAME=generic NUMBA_CACHE_DIR=$(CURDIR)/_build/numba-generic
test-notebooks-other: venv
	@mkdir -p _build/numba-generic
	$(GENERIC) OPENBLAS_NUM_THREADS=1 \
	$(BIN)/python -m pytest -p no:cacheprovider -n $(TEST_JOBS) $(NBVAL_DIST) book --nbval --nbval-current-env \
	--nbval-sanitize-with tests/nbval_sanitize.cfg -q

## make kernels: the compiled time loop (numba's disk cache) for both numerical environments, the
## machine's and the generic one, compiled side by side before the notebooks run (make test)
## by one nonlinear steady state each.  Left to the first use, every process that started before
## the cache was written compiled the loop again, 12 s each: in a fresh clone the two nbval
## workers and the data downloads of the first pass, and the two workers of the second.
KERNELS_USE := import warnings, fivebar; warnings.simplefilter("ignore"); \
	fivebar.steady_state(fivebar.Setup(fivebar.load_params(), steps_per_period=50))
kernels: kernels-native kernels-generic
kernels-native: venv
	$(BIN)/python -c '$(KERNELS_USE)'
kernels-generic: venv
	@mkdir -p _build/numba-generic
	$(GENERIC) $(BIN)/python -c '$(KERNELS_USE)'

## make book: the rendered HTML book in _build/html.  Sphinx warnings are errors (-W -n,
## --keep-going reports them all), a failing notebook cell fails the build, and notebook
## execution is cached (_build/.jupyter_cache): an unchanged rebuild takes seconds.
## The log is _build/book.log; _build/html/.fivebar-build-ok marks a successful build.
book: venv
	@mkdir -p _build && rm -f _build/html/.fivebar-build-ok
	set -eo pipefail; \
	$(BIN)/jupyter-book build . --builder html -W -n --keep-going 2>&1 | tee _build/book.log; \
	touch _build/html/.fivebar-build-ok

## make screenshots: every page of the table of contents at 1400 and 390 px wide as a reader sees
## it, in _build/screenshots/ (JPEG, whole pages; the browser test of tests/test_browser.py with
## FIVEBAR_SCREENSHOTS=1, its checks included).  `make test` runs the checks without them.
screenshots: book
	FIVEBAR_SCREENSHOTS=1 $(BIN)/python -m pytest -p no:cacheprovider tests/test_browser.py -q \
	-k test_page_reads_as_a_book

## make book-student: the student edition (no exercise solutions, neither in the pages, nor in
## the notebooks they offer for download, nor in its PDF) in _build/student/html, with the
## student archive of the chapters and data, _build/student/fivebar-student.zip, and (when TeX
## is there) the student PDF, both offered by its pages.  The instructor edition, with
## solutions, is `make book`.  Reuses the execution cache of `make book`.
book-student: venv
	@$(MAKE) --no-print-directory pdf-if-tex EDITION=student
	@$(MAKE) --no-print-directory book-student-html

## make book-student-html: the student edition's pages and archive only (they offer the student
## PDF if it has been built; make test builds it first, beside the instructor's)
book-student-html: venv
	@mkdir -p _build
	set -eo pipefail; \
	$(BIN)/python book/_ext/fivebar_build.py student 2>&1 | tee _build/student.log

## make pdf: the whole book as one PDF, _build/pdf/fivebar.pdf (EDITION=student:
## _build/pdf/fivebar-student.pdf), typeset by XeLaTeX from Sphinx's LaTeX build (TeX Live from
## Debian: see book/run.md); reuses the execution cache of `make book`.  An up-to-date PDF
## (newer than every source) is not built again.
EDITION ?= instructor
pdf: venv
	@mkdir -p _build
	set -eo pipefail; \
	$(BIN)/python book/_ext/fivebar_build.py pdf --edition $(EDITION) 2>&1 | tee _build/pdf$(if $(filter student,$(EDITION)),-student).log

HAVE_TEX = command -v xelatex >/dev/null && command -v latexmk >/dev/null && command -v makeindex >/dev/null
pdf-if-tex: venv
	@if $(HAVE_TEX); \
	then $(MAKE) --no-print-directory pdf EDITION=$(EDITION); \
	else echo "no XeLaTeX/latexmk/makeindex: no PDF (tests/test_pdf.py skips it; under CI it fails)"; fi

## make pdfs-if-tex: both editions' PDFs at once (each build is single-threaded; `make test`)
pdfs-if-tex: venv
	@if $(HAVE_TEX); \
	then $(MAKE) --no-print-directory -j$(BUILD_JOBS) -Otarget pdf-edition-instructor pdf-edition-student; \
	else echo "no XeLaTeX/latexmk/makeindex: no PDF (tests/test_pdf.py skips it; under CI it fails)"; fi

pdf-edition-%: venv
	@$(MAKE) --no-print-directory pdf EDITION=$*

## make datasets: the CSV files the book offers for download (book/_generated/data; the book
## builds write them when missing or stale: `make test` writes them beside the first nbval
## pass so that the two PDF builds that follow do not both compute them)
datasets: venv
	$(BIN)/python book/_ext/fivebar_build.py datasets

## make book-clean: force a full re-execution of every notebook and a full rebuild (and
## regenerate the CSV downloads and animation pages in book/_generated)
book-clean: venv
	rm -rf _build book/_generated
	$(MAKE) book

## make execute: re-execute every notebook in place (after a change of results)
execute: venv
	for nb in book/*.ipynb; do \
	echo "executing $$nb"; \
	$(BIN)/jupyter execute --inplace --timeout=600 "$$nb" || exit 1; \
	done

## make rerun PARAMS=mine.toml [CHAPTERS="09 12"] [RERUN_JOBS=2] [HTML=0]: rerun chapters (default:
## all) with your TOML files layered over the book's (papermill injects PARAMS_FILES after each
## chapter's parameters cell; the chapters are not edited): executed notebooks and their HTML
## pages in _build/rerun/<name>/ (book/run.md, "Change a parameter and rerun").  Fails, naming
## chapter and cell, on any cell error or failed physics check.
PARAMS ?=
CHAPTERS ?=
RERUN_JOBS ?= 2
HTML ?= 1
rerun: venv
	@test -n "$(PARAMS)" || { echo 'make rerun: give your files, e.g. make rerun PARAMS=mine.toml'; exit 2; }
	$(BIN)/python book/_ext/fivebar_rerun.py $(PARAMS) --jobs $(RERUN_JOBS) \
	$(if $(strip $(CHAPTERS)),--chapters $(CHAPTERS)) $(if $(filter 0,$(HTML)),--no-html)

## make rerun-examples: every chapter rerun with each file of examples/params/ (CI, after make
## test), every chapter with every file in one pool of RERUN_JOBS processes, the longest chapters
## first: fails on any cell error or failed physics check.  Notebooks only (no HTML pages); the
## matrix of outcomes (completes, says what does not apply, fails) and CPU seconds is printed and
## written to _build/rerun/matrix.md (book/run.md, "The rerun matrix").
## RERUN_FILES: the files of the matrix (default all of examples/params/; CI's matrix, chapters 14
## and 15 with l2_damping only, took 49 CPU-minutes, 25.5 minutes on 2 cores, on 2026-12-04;
## chapter 14 with mine.toml alone runs over 9 minutes).  RERUN_ONLY_WITH: chapters kept to some files,
## "NN=STEM[,STEM] ..." (CI: "14=l2_damping 15=l2_damping", every other chapter with every file).
RERUN_FILES ?= $(wildcard examples/params/*.toml)
RERUN_ONLY_WITH ?=
rerun-examples: venv
	$(BIN)/python book/_ext/fivebar_rerun.py $(RERUN_FILES) --each --jobs $(RERUN_JOBS) --no-html \
	$(if $(strip $(RERUN_ONLY_WITH)),--only-with $(RERUN_ONLY_WITH))

clean:
	rm -rf _build .pytest_cache book/_generated
