# Reference values of R strucchange for adaptid's tests (tests/diagnostics/test_strucchange_r.py).
# Run from the repository root:
#   Rscript tests/reference/strucchange/make_reference.R
# Needs R with strucchange (Debian: r-base-core r-cran-strucchange 1.5-3-1) and
# jsonlite-free output (written by hand below). Writes, next to this script:
#   Nile.csv, nhtemp.csv, UKDriverDeaths.csv  (R datasets package, public data)
#   reference.json                            (strucchange's results)
suppressMessages(library(strucchange))
dir <- "tests/reference/strucchange"
wcsv <- function(x, name) {
  write.csv(data.frame(time = as.numeric(time(x)), value = as.numeric(x)),
            file.path(dir, paste0(name, ".csv")), row.names = FALSE)
}
wcsv(Nile, "Nile"); wcsv(nhtemp, "nhtemp"); wcsv(UKDriverDeaths, "UKDriverDeaths")

num <- function(x) {
  x <- as.numeric(x)
  paste0("[", paste(ifelse(is.na(x), "null", sprintf("%.17g", x)), collapse = ", "), "]")
}
J <- list()
add <- function(key, value) J[[key]] <<- value

# The three models of strucchange's own examples:
#  nile:     Nile ~ 1                      (?breakpoints, ?Fstats, ?efp)
#  nhtemp:   nhtemp ~ 1                    (?Fstats)
#  seatbelt: y ~ ylag1 + ylag12 on log10(UKDriverDeaths), 1970(1)-1984(12) (?breakpoints)
seatbelt <- log10(UKDriverDeaths)
seatbelt <- cbind(seatbelt, lag(seatbelt, k = -1), lag(seatbelt, k = -12))
colnames(seatbelt) <- c("y", "ylag1", "ylag12")
seatbelt <- window(seatbelt, start = c(1970, 1), end = c(1984, 12))
models <- list(
  nile = list(f = Nile ~ 1, data = list(), h = 0.15),
  nhtemp = list(f = nhtemp ~ 1, data = list(), h = 0.15),
  seatbelt = list(f = y ~ ylag1 + ylag12, data = seatbelt, h = 0.1)
)
for (nm in names(models)) {
  m <- models[[nm]]; f <- m$f; d <- m$data
  for (type in c("Rec-CUSUM", "OLS-CUSUM", "Rec-MOSUM", "OLS-MOSUM", "RE", "ME")) {
    e <- if (length(d)) efp(f, data = d, type = type, h = 0.15) else efp(f, type = type, h = 0.15)
    st <- sctest(e)
    key <- paste(nm, "efp", type, sep = ".")
    add(paste0(key, ".process"), num(as.matrix(e$process)))
    add(paste0(key, ".ncol"), num(NCOL(e$process)))
    add(paste0(key, ".statistic"), num(st$statistic))
    add(paste0(key, ".pvalue"), num(st$p.value))
    add(paste0(key, ".boundary05"), num(boundary(e, alpha = 0.05)))
    add(paste0(key, ".boundary10"), num(boundary(e, alpha = 0.10)))
  }
  fs <- if (length(d)) Fstats(f, data = d, from = 0.15) else Fstats(f, from = 0.15)
  key <- paste(nm, "Fstats", sep = ".")
  add(paste0(key, ".F"), num(fs$Fstats))
  add(paste0(key, ".breakpoint"), num(fs$breakpoint))
  add(paste0(key, ".lambda"), num(fs$par))
  for (type in c("supF", "aveF", "expF")) {
    st <- sctest(fs, type = type)
    add(paste0(key, ".", type, ".statistic"), num(st$statistic))
    add(paste0(key, ".", type, ".pvalue"), num(st$p.value))
  }
  nh <- if (length(d)) sctest(f, data = d, type = "Nyblom-Hansen") else sctest(f, type = "Nyblom-Hansen")
  add(paste0(nm, ".nyblom.statistic"), num(nh$statistic))
  add(paste0(nm, ".nyblom.pvalue"), num(nh$p.value))
  ch <- if (length(d)) sctest(f, data = d, type = "Chow", point = 0.5) else sctest(f, type = "Chow", point = 0.5)
  add(paste0(nm, ".chow50.statistic"), num(ch$statistic))
  add(paste0(nm, ".chow50.pvalue"), num(ch$p.value))

  bp <- if (length(d)) breakpoints(f, data = d, h = m$h) else breakpoints(f, h = m$h)
  s <- summary(bp)
  key <- paste(nm, "breakpoints", sep = ".")
  add(paste0(key, ".h"), num(m$h))
  add(paste0(key, ".RSS"), num(s$RSS["RSS", ]))
  add(paste0(key, ".BIC"), num(s$RSS["BIC", ]))
  add(paste0(key, ".breakpoints"), num(bp$breakpoints))
  for (mb in seq_len(ncol(bp$RSS.table) / 2)) {
    add(paste0(key, ".m", mb), num(breakpoints(bp, breaks = mb)$breakpoints))
  }
  # BIC picks 0 breaks for the seatbelt model; ?breakpoints then uses breaks = 2
  bb <- if (any(is.na(bp$breakpoints))) 2 else length(bp$breakpoints)
  add(paste0(key, ".ci_breaks"), num(bb))
  ci <- confint(bp, breaks = bb, level = 0.95)$confint
  add(paste0(key, ".confint95"), num(t(ci)))     # per break: lower, bp, upper
  ci <- confint(bp, breaks = bb, level = 0.90)$confint
  add(paste0(key, ".confint90"), num(t(ci)))
  add(paste0(key, ".coef"), num(t(coef(bp, breaks = bb))))   # per segment: coefficients
}

# Monitoring (?mefp): Nile ~ 1 with the first 25 years as history, period 4.
nile_df <- data.frame(y = as.numeric(Nile))
hist <- nile_df[1:25, , drop = FALSE]
for (type in c("OLS-CUSUM", "ME")) {
  e <- efp(y ~ 1, data = hist, type = type, h = 0.5)
  mo <- mefp(e, alpha = 0.05, period = 4)
  full <- nile_df
  mo <- monitor(mo, data = full, verbose = FALSE)
  key <- paste("nile.monitor", type, sep = ".")
  add(paste0(key, ".breakpoint"), num(mo$breakpoint))
  add(paste0(key, ".critval"), num(mo$critval))
  add(paste0(key, ".process"), num(as.matrix(mo$process)))
  add(paste0(key, ".boundary"), num(boundary(mo)))
}

con <- file(file.path(dir, "reference.json"), "w")
cat("{\n", file = con)
keys <- names(J)
for (i in seq_along(keys)) {
  cat(sprintf('  "%s": %s%s\n', keys[i], J[[keys[i]]], if (i < length(keys)) "," else ""), file = con)
}
cat("}\n", file = con)
close(con)
cat("R", R.version$major, R.version$minor, "strucchange", as.character(packageVersion("strucchange")), "\n")
