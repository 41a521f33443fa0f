"""fsmctl/simulation"""
