# Command-line checks of `pvdfkit restore`: bad input exits 2 with a message naming the problem.
# Run by CTest: cmake -DPVDFKIT=... -DSRC=... -DWORK=... -P restore_cli.cmake
file(MAKE_DIRECTORY ${WORK})
set(EX ${SRC}/examples/restore)

function(expect code expected_text)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL code)
    message(FATAL_ERROR "expected exit ${code}, got ${rc}: ${ARGN}\n${out}\n${err}")
  endif()
  if(NOT "${expected_text}" STREQUAL "" AND NOT "${out}${err}" MATCHES "${expected_text}")
    message(FATAL_ERROR "output of ${ARGN} lacks '${expected_text}':\n${out}\n${err}")
  endif()
endfunction()

expect(0 "simulated" ${PVDFKIT} restore simulate ${EX}/edge_a.json -o ${WORK}/a.csv)
expect(0 "simulated" ${PVDFKIT} restore simulate ${EX}/edge_b.json -o ${WORK}/b.csv)
expect(0 "cond\\(F\\)" ${PVDFKIT} restore identify --scan ${WORK}/a.csv --force 0.6,0.9 --edge-x-m -0.0125
       --scan ${WORK}/b.csv --force 0.2,1.0 --edge-x-m -0.0125 --taps 2048 -o ${WORK}/f.json)
expect(0 "restored" ${PVDFKIT} restore apply ${WORK}/f.json ${WORK}/a.csv -o ${WORK}/forces.csv)
# The isotropic regularization is written into the filter file; an unknown one is refused.
expect(0 "isotropic regularization" ${PVDFKIT} restore identify --scan ${WORK}/a.csv --force 0.6,0.9 --edge-x-m -0.0125
       --scan ${WORK}/b.csv --force 0.2,1.0 --edge-x-m -0.0125 --taps 2048 --regularization isotropic -o ${WORK}/fi.json)
file(READ ${WORK}/fi.json fi_json)
if(NOT fi_json MATCHES "\"regularization\": *\"isotropic\"")
  message(FATAL_ERROR "fi.json lacks beta.regularization = isotropic")
endif()
expect(2 "--regularization" ${PVDFKIT} restore identify --scan ${WORK}/a.csv --force 0.6,0.9 --edge-x-m -0.0125
       --scan ${WORK}/b.csv --force 0.2,1.0 --edge-x-m -0.0125 --regularization wiener -o ${WORK}/fw.json)
file(STRINGS ${WORK}/forces.csv header LIMIT_COUNT 2)
if(NOT "${header}" MATCHES "x_m,fx_N,fz_N,mu")
  message(FATAL_ERROR "forces.csv header is '${header}'")
endif()
# Parallel force vectors are refused.
expect(2 "parallel" ${PVDFKIT} restore identify --scan ${WORK}/a.csv --force 0.3,0.45 --edge-x-m -0.0125
       --scan ${WORK}/b.csv --force 0.6,0.9 --edge-x-m -0.0125 -o ${WORK}/g.json)
# A wrong edge position leaves the window without signal: refused.
expect(2 "no signal" ${PVDFKIT} restore identify --scan ${WORK}/a.csv --force 0.6,0.9
       --scan ${WORK}/b.csv --force 0.2,1.0 -o ${WORK}/g.json)
# A malformed CSV row is reported with its line number.
file(WRITE ${WORK}/bad.csv "x_m,m1_V,m2_V\n")
foreach(i RANGE 1 40)
  if(i EQUAL 17)
    file(APPEND ${WORK}/bad.csv "0.1,oops,0.2\n")
  else()
    file(APPEND ${WORK}/bad.csv "${i}e-6,0.1,0.2\n")
  endif()
endforeach()
expect(2 "bad.csv:18" ${PVDFKIT} restore apply ${WORK}/f.json ${WORK}/bad.csv -o ${WORK}/x.csv)
# A malformed filter file names the key.
file(READ ${WORK}/f.json text)
string(REPLACE "\"h21\"" "\"h2_1\"" text "${text}")
file(WRITE ${WORK}/bad_filter.json "${text}")
expect(2 "h21" ${PVDFKIT} restore apply ${WORK}/bad_filter.json ${WORK}/a.csv -o ${WORK}/x.csv)
# A scene with an unknown key is refused.
file(WRITE ${WORK}/bad_scene.json "{\"scan\": {\"speed_m_per_sec\": 0.05}}")
expect(2 "speed_m_per_sec" ${PVDFKIT} restore simulate ${WORK}/bad_scene.json -o ${WORK}/x.csv)
# The forces CSV keeps its columns and adds the line forces in N/m.
if(NOT "${header}" MATCHES "x_m,fx_N,fz_N,mu,mu_valid,fx_N_per_m,fz_N_per_m")
  message(FATAL_ERROR "forces.csv lacks the N/m columns: '${header}'")
endif()
# A filter tap out of range (finite but absurd) is refused, naming the file, the key and the value.
file(READ ${WORK}/f.json text)
string(REGEX REPLACE "\"h22\": \\[\n *[-0-9.e+]+" "\"h22\": [\n  1e308" text "${text}")
file(WRITE ${WORK}/huge_tap.json "${text}")
expect(2 "huge_tap.json: filters: h22\\[0\\] = 1e\\+308 must be within" ${PVDFKIT} restore apply ${WORK}/huge_tap.json ${WORK}/a.csv -o ${WORK}/x.csv)
if(EXISTS ${WORK}/x.csv)
  message(FATAL_ERROR "a refused apply left ${WORK}/x.csv behind")
endif()
# Every numeric flag is range-checked where it is parsed (exit 2, the flag and its value).
expect(2 "--mu-threshold-N = -1 must be in" ${PVDFKIT} restore apply ${WORK}/f.json ${WORK}/a.csv -o ${WORK}/x.csv --mu-threshold-N -1)
expect(2 "--block = 0 must be in" ${PVDFKIT} restore apply ${WORK}/f.json ${WORK}/a.csv -o ${WORK}/x.csv --block 0)
expect(2 "--speed-m-per-s = -0.05 must be in" ${PVDFKIT} restore apply ${WORK}/f.json ${WORK}/a.csv -o ${WORK}/x.csv --speed-m-per-s -0.05)
expect(2 "--baseline-scale-m = 0 must be in" ${PVDFKIT} restore apply ${WORK}/f.json ${WORK}/a.csv -o ${WORK}/x.csv --baseline-scale-m 0)
set(ID_ARGS restore identify --scan ${WORK}/a.csv --force 0.6,0.9 --edge-x-m -0.0125 --scan ${WORK}/b.csv --force 0.2,1.0 --edge-x-m -0.0125 -o ${WORK}/g.json)
expect(2 "--taps = -5 must be in" ${PVDFKIT} ${ID_ARGS} --taps -5)
expect(2 "--beta = -3 must be in" ${PVDFKIT} ${ID_ARGS} --beta -3)
expect(2 "--resolution-m = -1 must be in" ${PVDFKIT} ${ID_ARGS} --resolution-m -1)
expect(2 "--low-cut-m = 1e\\+300 must be in" ${PVDFKIT} ${ID_ARGS} --low-cut-m 1e300)
expect(2 "--delay-samples = 9000 must be in" ${PVDFKIT} ${ID_ARGS} --delay-samples 9000)
expect(2 "--beta-corner-m = -0.001 must be in" ${PVDFKIT} ${ID_ARGS} --beta-corner-m -0.001)
expect(2 "--force FZ = 1e\\+09 must be in" ${PVDFKIT} restore identify --scan ${WORK}/a.csv --force 0.6,1e9 --edge-x-m -0.0125
       --scan ${WORK}/b.csv --force 0.2,1.0 --edge-x-m -0.0125 -o ${WORK}/g.json)
expect(2 "--edge-x-m = 1e\\+06 must be in" ${PVDFKIT} restore identify --scan ${WORK}/a.csv --force 0.6,0.9 --edge-x-m 1e6
       --scan ${WORK}/b.csv --force 0.2,1.0 --edge-x-m -0.0125 -o ${WORK}/g.json)
# The default identify (no beta flags) reports the chosen beta and why.
expect(0 "beta \\(predicted\\) = .*predicted at the identification forces" ${PVDFKIT} ${ID_ARGS})
# A scan at another speed (sample spacing) is refused unless resampled onto the filter's grid.
file(READ ${EX}/edge_a.json text)
string(REGEX REPLACE "\"speed_m_per_s\": [0-9.e+-]+" "\"speed_m_per_s\": 0.06" text "${text}")
file(WRITE ${WORK}/fast.json "${text}")
expect(0 "simulated" ${PVDFKIT} restore simulate ${WORK}/fast.json -o ${WORK}/fast.csv)
expect(2 "resample" ${PVDFKIT} restore apply ${WORK}/f.json ${WORK}/fast.csv -o ${WORK}/y.csv)
expect(0 "resampled" ${PVDFKIT} restore apply ${WORK}/f.json ${WORK}/fast.csv -o ${WORK}/y.csv --resample)
