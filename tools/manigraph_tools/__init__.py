"""manigraph stack tools: router, recorder, replay, doctor, run and up, over the contract."""
