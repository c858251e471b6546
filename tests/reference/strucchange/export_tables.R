# Exports the critical-value / p-value tables that R strucchange 1.5-3 keeps
# in its namespace (R/sysdata.rda) into src/adaptid/diagnostics/data/sc_tables.json
# (read by src/adaptid/diagnostics/_sc_tables.py). Numbers are written with 15
# significant digits, which read back to the same float64 in Python.
# Run from the repository root:  Rscript tests/reference/strucchange/export_tables.R
# Provenance of the tables (strucchange's documentation):
#   sc.beta.sup / sc.beta.ave / sc.beta.exp: Hansen (1997), "Approximate
#     asymptotic p values for structural-change tests", JBES 15(1):60-67,
#     response-surface coefficients for k = 1..40 and 25 trimmings
#     (rows (k-1)*25+1 .. k*25), used by strucchange:::pvalue.Fstats;
#   sc.me: critical values of the ME (moving estimates) test, Chu, Hornik &
#     Kuan (1995), rows (k-1)*10+1..k*10 for h = 0.05..0.5, columns
#     alpha = 0.1, 0.05, 0.025, 0.01, used by pvalue.efp(... increments);
#   sc.meanL2: quantiles of the mean L2 norm of a k-dim Brownian bridge
#     (Nyblom-Hansen), k = 1..25;
#   monitorMECritvalTable: Leisch, Hornik & Kuan (2000) critical values of
#     ME monitoring (max functional), winsize x period x 1-alpha.
suppressMessages(library(strucchange))
ns <- asNamespace("strucchange")
num <- function(r) paste0("[", paste(sprintf("%.15g", r), collapse = ", "), "]")
tab <- function(m) paste0("[\n", paste0("    ", apply(as.matrix(m), 1, num), collapse = ",\n"), "\n  ]")
out <- "src/adaptid/diagnostics/data/sc_tables.json"
items <- character(0)
add <- function(name, text) items <<- c(items, paste0('  "', name, '": ', text))
for (nm in c("sc.beta.sup", "sc.beta.ave", "sc.beta.exp", "sc.me", "sc.meanL2")) {
  add(toupper(gsub(".", "_", nm, fixed = TRUE)), tab(get(nm, envir = ns)))
}
add("SC_MEANL2_P", num(as.numeric(colnames(get("sc.meanL2", envir = ns)))))
mt <- get("monitorMECritvalTable", envir = ns)
add("MONITOR_ME_WINSIZE", "[0.25, 0.5, 1.0]")
add("MONITOR_ME_PERIOD", "[2, 4, 6, 8, 10]")
add("MONITOR_ME_PROB", num(as.numeric(dimnames(mt)[[3]])))
rows <- NULL
for (i in 1:3) for (j in 1:5) rows <- rbind(rows, mt[i, j, , "max"])
add("MONITOR_ME", tab(rows))  # 15 rows of 50: (winsize, period) in row-major order
src <- paste0("R strucchange ", as.character(packageVersion("strucchange")),
              ", R/sysdata.rda; written by tests/reference/strucchange/export_tables.R")
writeLines(c("{", paste0('  "source": "', src, '",'), paste(items, collapse = ",\n"), "}"), out)
