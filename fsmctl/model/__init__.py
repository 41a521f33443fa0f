"""fsmctl/model"""
