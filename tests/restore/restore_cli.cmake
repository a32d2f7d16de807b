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
