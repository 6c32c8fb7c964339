/* encal test stub: nothing of the motor module is needed on the host. */
